//! The constraint geometry of section 3 and Appendix A, as pure functions of positions:
//! Push, Pull and Resize on the guiding line (Fig. 4), the connector's angle limits, the
//! guiding line's collision test against the slave's own lidar, and Push-Pull-Rotate's
//! choice of where to go when that line is blocked (Fig. 5).

use std::f64::consts::PI;

use swarmrt_scenario::wrap_angle;

/// A point in the plane, metres.
pub type P = (f64, f64);

/// Which reaction of Fig. 4 a slave shows to its master's new position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reaction {
    /// Closer than `rod_min`: pushed away along the guiding line.
    Push,
    /// Farther than `rod_max`: pulled along the guiding line.
    Pull,
    /// Within the limits: the rod resizes, the slave stays.
    Resize,
}

/// Appendix A's `Adaptation` without obstacles: the slave at `slave` reacts to its master's
/// new position `master` on the guiding line from the master through the slave. Pull puts
/// it at `rod_max - lead` (`lead` is how far the master moved last tick: a slave process sees
/// its master one tick late, so it aims where the master's rod will end, not where it was);
/// Push at `rod_min`; Resize leaves it. A slave exactly on its master is pushed along `+x`.
pub fn adapt(master: P, slave: P, rod_min: f64, rod_max: f64, lead: f64) -> (Reaction, P) {
    let diff = (slave.0 - master.0, slave.1 - master.1);
    let d = diff.0.hypot(diff.1);
    let at = |len: f64| {
        if d < 1e-12 {
            (master.0 + len, master.1)
        } else {
            (master.0 + diff.0 * len / d, master.1 + diff.1 * len / d)
        }
    };
    if d > rod_max {
        (Reaction::Pull, at((rod_max - lead).max(rod_min).min(d)))
    } else if d < rod_min {
        (Reaction::Push, at(rod_min))
    } else {
        (Reaction::Resize, slave)
    }
}

/// The connector angle at `at` between its neighbours `a` and `b`, in radians in `[0, pi]`
/// (pi: the three in a straight line).
pub fn connector_angle(a: P, at: P, b: P) -> f64 {
    let ua = (a.1 - at.1).atan2(a.0 - at.0);
    let ub = (b.1 - at.1).atan2(b.0 - at.0);
    wrap_angle(ub - ua).abs()
}

/// Rotates `target` about the master `m` so that the connector angle at `m` between the
/// master's other neighbour `q` and `target` lies in `[min, max]` radians, on the side it
/// already is; the rod length is kept. Unchanged when already inside.
pub fn clamp_angle(q: P, m: P, target: P, min: f64, max: f64) -> P {
    let uq = (q.1 - m.1).atan2(q.0 - m.0);
    let ut = (target.1 - m.1).atan2(target.0 - m.0);
    let phi = wrap_angle(ut - uq);
    let inner = phi.abs();
    if (min..=max).contains(&inner) {
        return target;
    }
    let side = if phi < 0.0 { -1.0 } else { 1.0 };
    let a = uq + side * inner.clamp(min, max);
    let len = (target.0 - m.0).hypot(target.1 - m.1);
    (m.0 + len * a.cos(), m.1 + len * a.sin())
}

/// True when the straight line from the robot (the origin of its frame) to `to` (robot
/// frame) passes within `clearance` of a lidar hit (`hits`, robot frame). Hits within
/// `ignore` of `to` are the body of whoever stands there (the master), not an obstacle.
pub fn line_blocked(hits: &[P], to: P, clearance: f64, ignore: f64) -> bool {
    let d = to.0.hypot(to.1);
    if d < 1e-9 {
        return false;
    }
    let u = (to.0 / d, to.1 / d);
    hits.iter().any(|&h| {
        if (h.0 - to.0).hypot(h.1 - to.1) < ignore {
            return false;
        }
        let t = h.0 * u.0 + h.1 * u.1;
        if t <= 0.0 || t >= d {
            return false;
        }
        let perp = (h.0 - t * u.0).hypot(h.1 - t * u.1);
        perp < clearance
    })
}

/// Push-Pull-Rotate (Fig. 5): "the slave moves towards the old master position until the
/// guiding line defined by the new master position and the slave is collision free". Of the
/// master's remembered positions `trail` (oldest first, world frame), the newest one the
/// slave can reach in a straight, collision-free line, seen from `pose` (x, y, heading);
/// `None` when none is (the slave is trapped). In place of Appendix A's random "shaking"
/// of the colliding point ([`shake`], `behaviour.rotate = "shake"`), this searches where
/// the master has actually been, which is collision free by construction and needs no
/// randomness. No hit is ignored near a
/// trail point: nobody stands there to explain it away.
pub fn rotate_towards(
    pose: (f64, f64, f64),
    trail: impl DoubleEndedIterator<Item = P>,
    hits: &[P],
    clearance: f64,
) -> Option<P> {
    trail
        .rev()
        .find(|&c| !line_blocked(hits, to_robot_frame(pose, c), clearance, 0.0))
}

/// The point of the segment `a`-`b` nearest `a` at which it passes within `clearance` of a
/// hit (the rod's "obstacle collision point that is closest to the master" when `a` is the
/// master); hits within `ignore` of `a` are the body standing there. `None`: clear.
pub fn segment_collision(hits: &[P], a: P, b: P, clearance: f64, ignore: f64) -> Option<P> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let d = dx.hypot(dy);
    if d < 1e-9 {
        return None;
    }
    let u = (dx / d, dy / d);
    hits.iter()
        .filter(|h| (h.0 - a.0).hypot(h.1 - a.1) >= ignore)
        .filter_map(|h| {
            let (hx, hy) = (h.0 - a.0, h.1 - a.1);
            let t = hx * u.0 + hy * u.1;
            let perp = (hx - t * u.0).hypot(hy - t * u.1);
            (t > 0.0 && t < d && perp < clearance).then_some(t)
        })
        .min_by(f64::total_cmp)
        .map(|t| (a.0 + t * u.0, a.1 + t * u.1))
}

/// Appendix A's `ROTATE`, in the slave's frame (the slave at the origin, `m` its master,
/// `hits` its lidar): while the guiding line from the master through `slave_pos` (first the
/// slave itself) collides, `slave_pos := Sign(slave_pos - pos) * Random + pos` with `pos` the
/// collision point closest to the master, `Random` uniform in `[0, reach)` per axis (`draw`
/// gives `[0, 1)`). Returns the first `slave_pos` whose guiding line is clear and whose own
/// straight path from the slave to it is clear too (so the slave can move there), after at
/// most `tries` shakes; `None` when none is. The paper leaves `Random`'s scale open: `reach`
/// is one rod.
pub fn shake(
    m: P,
    hits: &[P],
    clearance: f64,
    ignore: f64,
    reach: f64,
    tries: u32,
    mut draw: impl FnMut() -> f64,
) -> Option<P> {
    let mut slave_pos = (0.0, 0.0);
    for _ in 0..tries {
        let Some(pos) = segment_collision(hits, m, slave_pos, clearance, ignore) else {
            if !line_blocked(hits, slave_pos, clearance, 0.0) {
                return Some(slave_pos);
            }
            // A clear guiding line the slave cannot reach: shake from where it stands.
            slave_pos = (0.0, 0.0);
            continue;
        };
        let sign = |v: f64| if v < 0.0 { -1.0 } else { 1.0 };
        let sx = sign(slave_pos.0 - pos.0) * draw() * reach;
        let sy = sign(slave_pos.1 - pos.1) * draw() * reach;
        slave_pos = (pos.0 + sx, pos.1 + sy);
    }
    None
}

/// `p` (world frame) in the frame of a robot at `pose` (x, y, heading).
pub fn to_robot_frame(pose: (f64, f64, f64), p: P) -> P {
    let (dx, dy) = (p.0 - pose.0, p.1 - pose.1);
    let (s, c) = pose.2.sin_cos();
    (c * dx + s * dy, -s * dx + c * dy)
}

/// Bearing beyond which [`steer`] drives backwards (120 degrees).
pub const REVERSE_BEYOND: f64 = 2.0 * PI / 3.0;

/// `(v, omega)` that drive a unicycle at `pose` towards `target`, forwards or (when the
/// target is well behind, more than [`REVERSE_BEYOND`] off the heading, as a pushed slave's
/// is) backwards: the turn rate is `gain` times the heading error, and the speed covers the
/// distance in one tick at most, scaled by the cosine of the error so the robot turns before
/// it drives sideways. Between 90 degrees and [`REVERSE_BEYOND`] it turns on the spot, so a
/// target abeam does not flip it between forwards and backwards every tick.
pub fn steer(
    pose: (f64, f64, f64),
    target: P,
    dt: f64,
    max_speed: f64,
    max_turn_rate: f64,
    gain: f64,
) -> (f64, f64) {
    let (dx, dy) = (target.0 - pose.0, target.1 - pose.1);
    let e = dx.hypot(dy);
    if e < 1e-3 {
        return (0.0, 0.0);
    }
    let bearing = wrap_angle(dy.atan2(dx) - pose.2);
    let (sign, err) = if bearing.abs() <= REVERSE_BEYOND {
        (1.0, bearing)
    } else {
        (-1.0, wrap_angle(bearing - PI))
    };
    let omega = (gain * err).clamp(-max_turn_rate, max_turn_rate);
    let v = sign * (e / dt).min(max_speed) * err.cos().max(0.0);
    (v, omega)
}
