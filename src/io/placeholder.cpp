namespace rbpf_slam { namespace io { int placeholder_io = 0; } }
