#!/usr/bin/env python3
"""Writes two bags one after the other into one, each message with its own header stamps (the
second log's stamps restart), the second's bag times shifted to follow the first's end by GAP
seconds: two logs in one bag, as a user who merged recordings would hand to offline_slam.
The second bag's /tf_static is left out (both come from the same robot description).

    join_bags.py FIRST.bag SECOND.bag OUT.bag [GAP]
"""
import sys

import rosbag
import rospy


def main(argv):
    if len(argv) not in (4, 5):
        sys.stderr.write(__doc__)
        return 2
    first, second, out_path = argv[1:4]
    gap = float(argv[4]) if len(argv) == 5 else 5.0
    with rosbag.Bag(out_path, 'w') as out:
        end = None
        with rosbag.Bag(first) as bag:
            for topic, msg, t in bag.read_messages(raw=True):
                out.write(topic, msg, t, raw=True)
                end = t if end is None or t > end else end
        with rosbag.Bag(second) as bag:
            shift = end + rospy.Duration(gap) - rospy.Time(bag.get_start_time())
            for topic, msg, t in bag.read_messages(raw=True):
                if topic.lstrip('/') == 'tf_static':
                    continue
                out.write(topic, msg, t + shift, raw=True)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
