#!/usr/bin/env python3
"""Emulate a Pioneer-style sonar ring at any rate from a laser bag and its reference trajectory.

The shared real logs (../shared/data/intel.bag, aces.bag) carry an 8-sonar ring only once per
laser scan (every ~3 s). This tool builds a stand-in for the ~4 Hz logs that issue 4 targets:

1. An occupancy grid of the building from the bag's laser scans (/scan) placed at the reference
   poses (REF.tum, one per scan): hits and pass-throughs per cell, a cell is a wall when it was hit
   often enough relative to the beams that passed through it (people walking by are dropped).
   Every wall cell keeps the mean of its laser end points and a surface normal from the end points
   around it (PCA over a small window), and how line-like that neighbourhood is.
2. Ring times every 1/RATE s over the reference's span; the robot pose at each is the reference
   interpolated along the odometry (the odometry's path between the two neighbouring reference
   poses, bent so that it meets both: the pose is exact at the scan stamps).
3. Each transducer (mounts from the bag's /tf_static base_link -> sonar_i) casts rays every
   RAY_SPACING deg over its cone; a ray's range is its first wall cell, refined to the cell's
   surface. As in the shared bags' emulation: nearest echo in the cone, no echo from a surface met
   beyond the critical incidence angle (specular, unless the neighbourhood is not a line: corners
   and clutter echo at any angle), MAX_RANGE (5 m) = no echo, Gaussian range noise.
4. A new bag: /odom, /tf, /tf_static copied from the input; /sonar (sensor_msgs/Range per
   transducer) and /sonar_cloud (sensor_msgs/PointCloud of the echoes in base_link) at the ring
   times. No /scan. And OUT.ref.tum: the interpolated reference at the ring stamps.

--check compares the emulation with the input bag's own rings at the scan stamps (same poses):
the fraction of transducers that agree (both no echo, or ranges within 0.1 m).

Example:
  /usr/bin/python3 tools/emulate_sonar_ring.py --bag ../shared/data/intel.bag \
      --reference ../shared/data/intel.ref.tum --output /tmp/intel_sonar4hz.bag --rate 4 --check
"""

import argparse
import math
import sys

import numpy as np


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def compose(a, b):
    """a (+) b for arrays of poses [..., 3]."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a):
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1], -a[..., 2]],
                    axis=-1)


def read_tum(path):
    rows = []
    with open(path) as f:
        for line in f:
            if not line.strip() or line.startswith('#'):
                continue
            t, x, y, _z, qx, qy, qz, qw = (float(v) for v in line.split()[:8])
            rows.append((t, x, y, math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))))
    a = np.array(rows)
    return a[:, 0], a[:, 1:4]


def interp_pose(stamps, poses, t):
    """Linear interpolation of poses [N, 3] at times t (clamped)."""
    i = np.clip(np.searchsorted(stamps, t) - 1, 0, len(stamps) - 2)
    s = np.clip((t - stamps[i]) / np.maximum(stamps[i + 1] - stamps[i], 1e-9), 0.0, 1.0)
    d = wrap(poses[i + 1, 2] - poses[i, 2])
    return np.stack([poses[i, 0] + s * (poses[i + 1, 0] - poses[i, 0]),
                     poses[i, 1] + s * (poses[i + 1, 1] - poses[i, 1]),
                     wrap(poses[i, 2] + s * d)], axis=-1)


def reference_along_odometry(ref_t, ref_p, odo_t, odo_p, t):
    """Reference pose at times t (inside [ref_t[0], ref_t[-1]]): the odometry's motion from each
    neighbouring reference pose, blended so that the result is exact at both."""
    i = np.clip(np.searchsorted(ref_t, t, side='right') - 1, 0, len(ref_t) - 2)
    o_t = interp_pose(odo_t, odo_p, t)
    o0 = interp_pose(odo_t, odo_p, ref_t[i])
    o1 = interp_pose(odo_t, odo_p, ref_t[i + 1])
    a = compose(ref_p[i], compose(inverse(o0), o_t))
    b = compose(ref_p[i + 1], compose(inverse(o1), o_t))
    s = np.clip((t - ref_t[i]) / np.maximum(ref_t[i + 1] - ref_t[i], 1e-9), 0.0, 1.0)
    d = wrap(b[:, 2] - a[:, 2])
    return np.stack([(1 - s) * a[:, 0] + s * b[:, 0], (1 - s) * a[:, 1] + s * b[:, 1],
                     wrap(a[:, 2] + s * d)], axis=-1)


def box_sum(a, r):
    """Sum of a 2-D array over a (2r+1)^2 window (zero outside)."""
    p = np.pad(a, (r + 1, r))
    c = p.cumsum(0).cumsum(1)
    n = 2 * r + 1
    return c[n:, n:] - c[:-n, n:] - c[n:, :-n] + c[:-n, :-n]


class Grid:
    def __init__(self, scans, poses, res, max_free_m, min_hits, min_hit_ratio, normal_radius_m):
        self.res = res
        pts = []
        for (angles, ranges), pose in zip(scans, poses):
            finite = np.isfinite(ranges) & (ranges > 0.05)
            a = pose[2] + angles[finite]
            r = ranges[finite]
            pts.append(np.stack([pose[0] + r * np.cos(a), pose[1] + r * np.sin(a)], 1))
        pts = np.concatenate(pts)
        lo = pts.min(0) - 6.0
        hi = pts.max(0) + 6.0
        self.origin = lo
        self.shape = tuple(np.ceil((hi - lo) / res).astype(int) + 1)
        n = self.shape[0] * self.shape[1]
        fi = self._flat(pts)
        hits = np.bincount(fi, minlength=n).astype(float)
        # Free space: along every beam up to one cell and a half before its end point (or
        # max_free_m); sampled every half cell, so a beam counts ~2 per cell it crosses.
        passes = np.zeros(n)
        steps = np.arange(0.0, max_free_m, 0.5 * res)[None, :]
        for (angles, ranges), pose in zip(scans, poses):
            finite = np.isfinite(ranges) & (ranges > 0.05)
            a = pose[2] + angles
            reach = np.where(finite, np.minimum(np.where(finite, ranges, 0.0), max_free_m + res)
                             - 1.5 * res, max_free_m)
            mask = steps < reach[:, None]
            fx = (pose[0] + steps * np.cos(a)[:, None])[mask]
            fy = (pose[1] + steps * np.sin(a)[:, None])[mask]
            passes += np.bincount(self._flat(np.stack([fx, fy], 1)), minlength=n)
        passes *= 0.5
        occ = (hits >= min_hits) & (hits >= min_hit_ratio * (hits + passes))
        self.occ = occ.reshape(self.shape)
        sx = np.bincount(fi, weights=pts[:, 0], minlength=n).reshape(self.shape)
        sy = np.bincount(fi, weights=pts[:, 1], minlength=n).reshape(self.shape)
        h = hits.reshape(self.shape)
        with np.errstate(invalid='ignore', divide='ignore'):
            self.mean = np.stack([sx / h, sy / h], -1)
        # Normals: PCA of the wall cells' mean points in a window around each.
        w = self.occ.astype(float)
        mx = np.where(self.occ, self.mean[..., 0], 0.0)
        my = np.where(self.occ, self.mean[..., 1], 0.0)
        r = max(1, int(round(normal_radius_m / res)))
        N = box_sum(w, r)
        Sx, Sy = box_sum(mx, r), box_sum(my, r)
        Sxx, Syy, Sxy = box_sum(mx * mx, r), box_sum(my * my, r), box_sum(mx * my, r)
        with np.errstate(invalid='ignore', divide='ignore'):
            cxx = Sxx / N - (Sx / N) ** 2
            cyy = Syy / N - (Sy / N) ** 2
            cxy = Sxy / N - (Sx / N) * (Sy / N)
        cxx, cyy, cxy = (np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0) for v in (cxx, cyy, cxy))
        tr = cxx + cyy
        det = cxx * cyy - cxy * cxy
        disc = np.sqrt(np.maximum(tr * tr / 4 - det, 0.0))
        l_small = tr / 2 - disc
        l_big = tr / 2 + disc
        # Normal = eigenvector of the smallest eigenvalue.
        ang = 0.5 * np.arctan2(2 * cxy, cxx - cyy) + np.pi / 2
        self.normal = np.stack([np.cos(ang), np.sin(ang)], -1)
        with np.errstate(invalid='ignore', divide='ignore'):
            self.linear = (N >= 3) & (l_small < 0.2 * l_big)
        self.linear &= self.occ

    def _flat(self, p):
        ij = np.floor((p - self.origin) / self.res).astype(int)
        ij[:, 0] = np.clip(ij[:, 0], 0, self.shape[0] - 1)
        ij[:, 1] = np.clip(ij[:, 1], 0, self.shape[1] - 1)
        return ij[:, 0] * self.shape[1] + ij[:, 1]

    def cast(self, ox, oy, ang, max_range, step, critical):
        """Rays from (ox, oy) [R] at angles ang [R]: range of the first wall cell (refined to the
        surface; inf: nothing within max_range), and whether that surface is met at grazing
        incidence (beyond critical, and line-like)."""
        d = np.arange(step, max_range + 2 * step, step)
        cx, sx = np.cos(ang), np.sin(ang)
        px = ox[:, None] + d[None, :] * cx[:, None]
        py = oy[:, None] + d[None, :] * sx[:, None]
        ix = np.floor((px - self.origin[0]) / self.res).astype(int)
        iy = np.floor((py - self.origin[1]) / self.res).astype(int)
        inside = (ix >= 0) & (iy >= 0) & (ix < self.shape[0]) & (iy < self.shape[1])
        ix = np.clip(ix, 0, self.shape[0] - 1)
        iy = np.clip(iy, 0, self.shape[1] - 1)
        hit = self.occ[ix, iy] & inside
        any_hit = hit.any(1)
        k = hit.argmax(1)
        rows = np.arange(len(ang))
        hx, hy = ix[rows, k], iy[rows, k]
        n = self.normal[hx, hy]
        m = self.mean[hx, hy]
        ndotd = n[:, 0] * cx + n[:, 1] * sx
        cosinc = np.abs(ndotd)
        with np.errstate(invalid='ignore', divide='ignore'):
            t = (n[:, 0] * (m[:, 0] - ox) + n[:, 1] * (m[:, 1] - oy)) / ndotd
        coarse = d[k]
        linear = self.linear[hx, hy]
        t = np.where(linear & np.isfinite(t), np.clip(t, coarse - self.res, coarse + self.res), coarse)
        # Grazing: a line-like surface met beyond the critical incidence (corners and clutter,
        # not line-like, echo at any angle).
        grazing = linear & (cosinc < math.cos(critical))
        return np.where(any_hit & (t <= max_range), t, np.inf), grazing


def read_input(bag_path):
    import rosbag
    scans, scan_t, odo, odo_t, mounts, rings = [], [], [], [], {}, {}
    static = None
    with rosbag.Bag(bag_path) as bag:
        for topic, msg, _t in bag.read_messages(topics=['/scan', '/odom', '/tf_static', '/sonar']):
            if topic == '/scan':
                ang = msg.angle_min + msg.angle_increment * np.arange(len(msg.ranges))
                scans.append((ang, np.array(msg.ranges, dtype=float)))
                scan_t.append(msg.header.stamp.to_sec())
            elif topic == '/odom':
                p = msg.pose.pose
                odo.append((p.position.x, p.position.y, yaw_of(p.orientation)))
                odo_t.append(msg.header.stamp.to_sec())
            elif topic == '/tf_static':
                static = msg
                for tr in msg.transforms:
                    if tr.child_frame_id.startswith('sonar_'):
                        i = int(tr.child_frame_id.split('_')[1])
                        mounts[i] = (tr.transform.translation.x, tr.transform.translation.y,
                                     yaw_of(tr.transform.rotation))
            elif topic == '/sonar':
                i = int(msg.header.frame_id.split('_')[1])
                rings.setdefault(msg.header.stamp.to_sec(), {})[i] = msg.range
    m = np.array([mounts[i] for i in sorted(mounts)])
    return scans, np.array(scan_t), np.array(odo), np.array(odo_t), m, static, rings


def emulate(grid, poses, mounts, fov, max_range, ray_spacing_deg, step, critical, drop, noise, rng,
            from_base=True, batch=64):
    """Ranges [len(poses), len(mounts)]; max_range = no echo. from_base: the cone's apex and the
    range are at the base origin (as in the shared bags), else at the transducer. The nearest
    surface in the cone echoes, unless it is met at grazing incidence: then no echo with
    probability drop (specular)."""
    n_rays = 1 + int(math.ceil(math.degrees(fov) / ray_spacing_deg))
    offs = np.linspace(-fov / 2, fov / 2, n_rays)
    out = np.empty((len(poses), len(mounts)))
    for b0 in range(0, len(poses), batch):
        P = poses[b0:b0 + batch]
        M = mounts.copy()
        if from_base:
            M[:, :2] = 0.0
        S = compose(np.repeat(P, len(mounts), 0), np.tile(M, (len(P), 1)))  # [B*M, 3]
        ox = np.repeat(S[:, 0], n_rays)
        oy = np.repeat(S[:, 1], n_rays)
        ang = (S[:, 2][:, None] + offs[None, :]).ravel()
        t, grazing = grid.cast(ox, oy, ang, max_range, step, critical)
        t = t.reshape(len(S), n_rays)
        k = t.argmin(1)
        r = t[np.arange(len(S)), k]
        specular = grazing.reshape(len(S), n_rays)[np.arange(len(S)), k] & (rng.random(len(S)) < drop)
        r = np.where(specular, np.inf, r)
        echo = np.isfinite(r)
        r = np.where(echo, r + rng.normal(0.0, noise, r.shape), max_range)
        r = np.where(echo, np.clip(r, 0.1, max_range - 1e-3), max_range)
        out[b0:b0 + len(P)] = r.reshape(len(P), len(mounts))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--bag', required=True)
    ap.add_argument('--reference', required=True, help='TUM reference at the scan stamps')
    ap.add_argument('--output', help='bag to write (and OUTPUT minus .bag + .ref.tum)')
    ap.add_argument('--rate', type=float, default=4.0, help='rings per second')
    ap.add_argument('--resolution', type=float, default=0.05, help='grid cell, m')
    ap.add_argument('--max-range', type=float, default=5.0)
    ap.add_argument('--fov-deg', type=float, default=30.0)
    ap.add_argument('--ray-spacing-deg', type=float, default=1.0)
    ap.add_argument('--critical-deg', type=float, default=30.0,
                    help='incidence beyond which a line-like surface is grazing')
    ap.add_argument('--drop', type=float, default=0.8,
                    help='probability of no echo when the nearest surface is grazing')
    ap.add_argument('--noise', type=float, default=0.03, help='range noise sigma, m')
    ap.add_argument('--min-hits', type=int, default=2)
    ap.add_argument('--min-hit-ratio', type=float, default=0.2)
    ap.add_argument('--seed', type=int, default=1)
    ap.add_argument('--range-from', choices=['base', 'transducer'], default='base',
                    help='apex of the cone and origin of the range: base (base_link origin, as '
                    'the shared intel/aces bags do) or transducer (physical)')
    ap.add_argument('--perfect-odometry', action='store_true',
                    help='diagnostic: /odom and /tf odom -> base_link are the interpolated '
                    'reference at the ring times (no drift) instead of the input\'s')
    ap.add_argument('--odometry-from', metavar='BAG',
                    help='take /odom and /tf from this bag instead (another odometry-noise draw of '
                         'the same log, e.g. carmen_to_bag --seed K; its stamps must match)')
    ap.add_argument('--check', action='store_true',
                    help='compare with the input bag\'s own rings at the scan stamps')
    args = ap.parse_args()

    scans, scan_t, odo, odo_t, mounts, static, rings = read_input(args.bag)
    if not len(mounts):
        sys.exit('%s: no base_link -> sonar_i transforms in /tf_static' % args.bag)
    odometry_bag = args.odometry_from or args.bag
    if args.odometry_from:
        _, _, odo, odo_t, _, _, _ = read_input(args.odometry_from)
        if not len(odo):
            sys.exit('%s: no /odom messages' % args.odometry_from)
    ref_t, ref_p = read_tum(args.reference)
    # Scans and reference share stamps; keep the scans that have a reference pose.
    idx = np.searchsorted(ref_t, scan_t)
    idx = np.clip(idx, 0, len(ref_t) - 1)
    ok = np.abs(ref_t[idx] - scan_t) < 1e-3
    grid = Grid([s for s, k in zip(scans, ok) if k], ref_p[idx[ok]], args.resolution, 8.0,
                args.min_hits, args.min_hit_ratio, 0.15)
    print('grid %dx%d cells of %.2f m, %d walls (%.0f%% line-like)' %
          (grid.shape[0], grid.shape[1], grid.res, grid.occ.sum(),
           100.0 * grid.linear.sum() / max(1, grid.occ.sum())), file=sys.stderr)
    rng = np.random.default_rng(args.seed)
    fov = math.radians(args.fov_deg)
    critical = math.radians(args.critical_deg)
    step = 0.4 * args.resolution

    if args.check:
        st = np.array(sorted(rings))
        st = st[(st >= ref_t[0]) & (st <= ref_t[-1])]
        P = reference_along_odometry(ref_t, ref_p, odo_t, odo, st)
        # Its own random numbers: the bag written below is the same with or without --check.
        em = emulate(grid, P, mounts, fov, args.max_range, args.ray_spacing_deg, step, critical,
                     args.drop, args.noise, np.random.default_rng([args.seed, 1]),
                     args.range_from == 'base')
        sh = np.array([[rings[t].get(i, args.max_range) for i in range(len(mounts))] for t in st])
        e_no, s_no = em >= args.max_range - 1e-3, sh >= args.max_range - 1e-3
        both = ~e_no & ~s_no
        agree = (e_no & s_no) | (both & (np.abs(em - sh) < 0.1))
        print('check at %d scan stamps x %d transducers: agree %.1f%% (both no echo %.1f%%, '
              'echo within 0.1 m %.1f%% of %.1f%% both echo, median |diff| %.3f m); echo rate '
              'emulated %.1f%%, shared %.1f%%; only emulated echoes %.1f%%, only shared %.1f%%' %
              (len(st), len(mounts), 100 * agree.mean(), 100 * (e_no & s_no).mean(),
               100 * (both & (np.abs(em - sh) < 0.1)).mean(), 100 * both.mean(),
               np.median(np.abs(em - sh)[both]) if both.any() else float('nan'),
               100 * (~e_no).mean(), 100 * (~s_no).mean(), 100 * (~e_no & s_no).mean(),
               100 * (e_no & ~s_no).mean()))
        print('per transducer agree: ' + ' '.join('%.0f%%' % (100 * agree[:, i].mean())
                                                 for i in range(len(mounts))))

    if not args.output:
        return
    import rosbag
    import rospy
    # Message classes from the input bag (Debian's ROS has no Python sensor_msgs/geometry_msgs).
    Range = PointCloud = Point32 = None
    with rosbag.Bag(args.bag) as src:
        for topic, msg, _t in src.read_messages(topics=['/sonar', '/sonar_cloud']):
            if topic == '/sonar':
                Range = type(msg)
            elif msg.points:
                PointCloud, Point32 = type(msg), type(msg.points[0])
            if Range and PointCloud:
                break

    ring_t = np.arange(ref_t[0], ref_t[-1], 1.0 / args.rate)
    P = reference_along_odometry(ref_t, ref_p, odo_t, odo, ring_t)
    R = emulate(grid, P, mounts, fov, args.max_range, args.ray_spacing_deg, step, critical,
                args.drop, args.noise, rng, args.range_from == 'base')
    ref_out = args.output[:-4] if args.output.endswith('.bag') else args.output
    with open(ref_out + '.ref.tum', 'w') as f:
        for t, p in zip(ring_t, P):
            f.write('%.6f %.6f %.6f 0 0 0 %.9f %.9f\n' % (t, p[0], p[1], math.sin(p[2] / 2), math.cos(p[2] / 2)))
    with rosbag.Bag(odometry_bag) as src, rosbag.Bag(args.output, 'w') as out:
        out.write('/tf_static', static, static.transforms[0].header.stamp)
        import copy
        odo_msg = tf_msg = None
        for topic, msg, t in src.read_messages(topics=['/odom', '/tf']):
            if args.perfect_odometry:
                if topic == '/odom':
                    odo_msg = msg
                else:
                    tf_msg = msg
                continue
            out.write(topic, msg, t)
        if args.perfect_odometry:
            for k, (t, p) in enumerate(zip(ring_t, P)):
                stamp = rospy.Time.from_sec(float(t))
                o = copy.deepcopy(odo_msg)
                o.header.seq = k
                o.header.stamp = stamp
                o.pose.pose.position.x, o.pose.pose.position.y = float(p[0]), float(p[1])
                o.pose.pose.orientation.z = math.sin(p[2] / 2)
                o.pose.pose.orientation.w = math.cos(p[2] / 2)
                tf = copy.deepcopy(tf_msg)
                tr = tf.transforms[0]
                tr.header.stamp = stamp
                tr.transform.translation.x, tr.transform.translation.y = float(p[0]), float(p[1])
                tr.transform.rotation.z = math.sin(p[2] / 2)
                tr.transform.rotation.w = math.cos(p[2] / 2)
                out.write('/odom', o, stamp)
                out.write('/tf', tf, stamp)
        for k, (t, ranges) in enumerate(zip(ring_t, R)):
            stamp = rospy.Time.from_sec(float(t))
            cloud = PointCloud()
            cloud.header.seq = k
            cloud.header.stamp = stamp
            cloud.header.frame_id = 'base_link'
            for i, r in enumerate(ranges):
                m = Range()
                m.header.seq = k
                m.header.stamp = stamp
                m.header.frame_id = 'sonar_%d' % i
                m.radiation_type = 0  # ULTRASOUND
                m.field_of_view = fov
                m.min_range = 0.1
                m.max_range = args.max_range
                m.range = float(r)
                out.write('/sonar', m, stamp)
                if r < args.max_range - 1e-3:
                    x, y, a = mounts[i]
                    cloud.points.append(Point32(x + r * math.cos(a), y + r * math.sin(a), 0.0))
            out.write('/sonar_cloud', cloud, stamp)
    print('wrote %s: %d rings at %.1f Hz over %.0f s, %.1f%% echoes; %s.ref.tum' %
          (args.output, len(ring_t), args.rate, ring_t[-1] - ring_t[0],
           100.0 * (R < args.max_range - 1e-3).mean(), ref_out), file=sys.stderr)


if __name__ == '__main__':
    main()
