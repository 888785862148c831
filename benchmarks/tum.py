"""Reads planar TUM trajectories (`t x y z qx qy qz qw` per line, `#` comments) for the
benchmark tools, with the checks of the C++ reader (src/io/trajectory.cpp): 8 finite numbers
per line, a non-zero quaternion, and an error that names the file and line.

The yaw is the scale-free z-y-x Euler yaw, as in C++, so an unnormalised quaternion gives the
same heading as its normalised form.
"""

import math


class TumError(ValueError):
    """A trajectory file that cannot be read; the message names the file (and line)."""


def yaw_from_quaternion(qx, qy, qz, qw):
    return math.atan2(2.0 * (qw * qz + qx * qy), qw * qw + qx * qx - qy * qy - qz * qz)


def read_tum(path, min_poses=1):
    """A list of (stamp, x, y, yaw) tuples, in file order.

    Raises TumError when the file cannot be opened, a line is not 8 finite numbers, a
    quaternion is zero, or it holds fewer than min_poses poses."""
    rows = []
    try:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                text = line.strip()
                if not text or text.startswith("#"):
                    continue
                fields = text.split()
                if len(fields) != 8:
                    raise TumError("%s:%d: expected 8 numbers (t x y z qx qy qz qw), got %d"
                                   % (path, number, len(fields)))
                try:
                    v = [float(x) for x in fields]
                except ValueError:
                    raise TumError("%s:%d: not a number in '%s'" % (path, number, text)) from None
                if not all(math.isfinite(x) for x in v):
                    raise TumError("%s:%d: non-finite value in '%s'" % (path, number, text))
                if v[4] == v[5] == v[6] == v[7] == 0.0:
                    raise TumError("%s:%d: quaternion is zero" % (path, number))
                rows.append((v[0], v[1], v[2], yaw_from_quaternion(*v[4:8])))
    except OSError as error:
        raise TumError("%s: cannot read trajectory: %s" % (path, error.strerror or error)) from None
    except UnicodeDecodeError:
        raise TumError("%s: not a text file" % path) from None
    if len(rows) < min_poses:
        raise TumError("%s: %d poses, need at least %d" % (path, len(rows), min_poses))
    return rows


def stamps_and_xy(path, min_poses=1):
    """(stamps, xy) numpy arrays of read_tum(path): shapes (N,) and (N, 2)."""
    import numpy as np  # only here: read_tum needs no numpy
    rows = np.array(read_tum(path, min_poses), dtype=float).reshape(-1, 4)
    return rows[:, 0], rows[:, 1:3]
