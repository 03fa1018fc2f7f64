//! Stage `sensing`: each robot's [`Observation`] (noisy pose, lidar against the map and the
//! other bodies, range-and-bearing, goal sensor, inbox), and the goal check after each step.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering as AtomicOrdering};

use rand_distr::{Distribution, Normal};
use swarmrt_protocol::{
    Frame, MAX_INBOX, MAX_LIDAR_RAYS, MAX_NEIGHBOURS, Neighbour, Observation, RobotState,
};

use super::{Event, Robot, Stage, World, wrap_angle};
use crate::grid::Grid;
use crate::map::Map;
use crate::radio::RadioMedium;
use crate::rng::Rng;

impl World {
    /// Fills `out[i]` with robot i's observation of the current tick. Draws sensor noise, so
    /// call it exactly once per tick.
    ///
    /// From [`PARALLEL_OBSERVE_MIN`] robots on, the robots are observed on scoped threads (at
    /// most [`OBSERVE_THREADS`]) that take [`OBSERVE_CHUNK`] at a time: each observation reads
    /// only shared state and its own robot's noise stream, so the result is the same bytes. In
    /// process mode the robots sleep while the world observes, so the other cores are free
    /// (a scoped thread costs ~50 us here; at 100 robots two threads take 226 us, one 290 us).
    pub fn observe(&mut self, out: &mut [Observation]) {
        self.observe_on(out, worker_threads(self.robots.len(), PARALLEL_OBSERVE_MIN));
    }

    /// [`World::observe`] on exactly `threads` threads (at least one): the same bytes for
    /// any count.
    pub fn observe_on(&mut self, out: &mut [Observation], threads: usize) {
        let mut none = vec![(); out.len()];
        self.observe_then(out, &mut none, threads, |_, _, _| {});
    }

    /// [`World::observe_on`], and right after robot i's observation is filled, `then(i,
    /// &out[i], &mut items[i])` on the same thread (the in-process loop's robots answer there,
    /// while the observation is still in cache). Threads take [`OBSERVE_CHUNK`] robots at a
    /// time until none are left, so a thread slowed by a neighbour on its core leaves its share
    /// to the others. Each robot's observation reads only shared state and its own noise
    /// stream, so the bytes are the same whichever thread fills which robot; `then` must also
    /// touch only `items[i]` and the observation for that to hold of what it does.
    ///
    /// With timing on, the sensing stage includes the time spent in `then`.
    pub fn observe_then<T: Send>(
        &mut self,
        out: &mut [Observation],
        items: &mut [T],
        threads: usize,
        then: impl Fn(usize, &Observation, &mut T) + Sync,
    ) {
        assert_eq!(
            out.len(),
            self.robots.len(),
            "one observation slot per robot"
        );
        self.observe_inner(Some(out), items, threads, then);
    }

    /// [`World::observe_then`] without keeping the observations: each thread fills one
    /// observation of its own per robot and hands it to `then`, which must take what it needs
    /// from it. The ~6 KB per robot stay in cache instead of going out to a slice of them all
    /// (60 MB a tick at 10,000 robots). The same bytes reach `then`.
    pub fn observe_each<T: Send>(
        &mut self,
        items: &mut [T],
        threads: usize,
        then: impl Fn(usize, &Observation, &mut T) + Sync,
    ) {
        self.observe_inner(None, items, threads, then);
    }

    /// [`World::observe_then`] into `out`, or [`World::observe_each`] when `out` is `None`.
    fn observe_inner<T: Send>(
        &mut self,
        out: Option<&mut [Observation]>,
        items: &mut [T],
        threads: usize,
        then: impl Fn(usize, &Observation, &mut T) + Sync,
    ) {
        let start = self.stage_times.start();
        let n = self.robots.len();
        assert_eq!(items.len(), n, "one item per robot");
        let positions: Vec<(f64, f64)> = self.robots.iter().map(|r| (r.x, r.y)).collect();
        let lidar = &self.cfg.robots.lidar;
        let rb_range = self.cfg.robots.range_bearing.range;
        let radius = self.cfg.robots.radius;
        // One neighbour query per robot serves the lidar (bodies within range + radius) and
        // range-and-bearing. Cells about a third of that reach keep the candidates close to
        // the disc (results do not depend on the cell size: candidates are filtered by
        // distance and sorted).
        let reach = (lidar.range + radius).max(rb_range);
        let grid = Grid::build(&positions, (reach / 3.0).max(4.0 * radius));
        let ctx = ObserveCtx {
            robots: &self.robots,
            map: &self.map,
            grid: &grid,
            radio: &self.radio,
            ray_angles: (0..(lidar.rays as usize).min(MAX_LIDAR_RAYS))
                .map(|k| lidar.ray_angle(k))
                .collect(),
            tick: self.tick,
            lidar,
            rb_range,
            radius,
            reach,
            reach_sq: reach_sq(reach),
            noise: self.cfg.robots.noise,
            cfg: &self.cfg,
            goal_sensor: self.cfg.robots.goal_sensor,
        };
        let rngs = &mut self.sensor_rng[..];
        let work = |first: usize,
                    mut outs: Option<&mut [Observation]>,
                    rngs: &mut [Rng],
                    items: &mut [T],
                    own: &mut Observation,
                    scratch: &mut Scratch| {
            for (k, (rng, item)) in rngs.iter_mut().zip(items).enumerate() {
                let o = match outs.as_deref_mut() {
                    Some(outs) => &mut outs[k],
                    None => &mut *own,
                };
                ctx.observe_one(first + k, o, rng, scratch);
                clear_unused(o);
                then(first + k, o, item);
            }
        };
        let own = || Box::new(Observation::empty(0, 0));
        if threads <= 1 || n < 2 {
            work(0, out, rngs, items, &mut own(), &mut Scratch::default());
        } else {
            let mut outs = out.map(|o| o.chunks_mut(OBSERVE_CHUNK));
            let chunks: Vec<Mutex<Chunk<'_, T>>> = rngs
                .chunks_mut(OBSERVE_CHUNK)
                .zip(items.chunks_mut(OBSERVE_CHUNK))
                .map(|(rngs, items)| {
                    let outs = outs.as_mut().and_then(|o| o.next());
                    Mutex::new((outs, rngs, items))
                })
                .collect();
            let next = AtomicUsize::new(0);
            let run = || {
                let mut scratch = Scratch::default();
                let mut own = own();
                loop {
                    let c = next.fetch_add(1, AtomicOrdering::Relaxed);
                    let Some(chunk) = chunks.get(c) else { break };
                    let mut chunk = chunk.lock().unwrap_or_else(|e| e.into_inner());
                    let (outs, rngs, items) = &mut *chunk;
                    let outs = outs.as_deref_mut();
                    work(c * OBSERVE_CHUNK, outs, rngs, items, &mut own, &mut scratch);
                }
            };
            std::thread::scope(|s| {
                for _ in 1..threads {
                    s.spawn(run);
                }
                run();
            });
        }
        for r in &self.robots {
            if r.state == RobotState::Active && r.lidar_on {
                self.metrics.lidar_on_ticks += 1;
            }
        }
        self.stage_times.stop(Stage::Sensing, start);
    }

    /// Notes every active robot that entered the goal radius for the first time.
    pub(super) fn check_goal(&mut self) {
        for r in &mut self.robots {
            let g = self.cfg.goal_of(r.id);
            // Aerial robots reach their goal in 3D (goal_of gives them a height).
            let dz = g.z.map_or(0.0, |z| r.z - z);
            if r.reached_tick.is_none()
                && r.state == RobotState::Active
                && (r.x - g.x).powi(2) + (r.y - g.y).powi(2) + dz * dz <= g.radius * g.radius
            {
                r.reached_tick = Some(self.tick);
                self.metrics.reached_target += 1;
                self.events.push(Event::Reached {
                    tick: self.tick,
                    robot: r.id,
                });
            }
        }
    }
}

/// Gaussian noise with standard deviation `sd`; draws nothing when `sd` is zero so a
/// noiseless run consumes no randomness.
fn gauss(rng: &mut Rng, sd: f64) -> f64 {
    if sd > 0.0 {
        Normal::new(0.0, sd).map(|d| d.sample(rng)).unwrap_or(0.0)
    } else {
        0.0
    }
}

/// Robots from which [`World::observe`] splits the robots over threads (below, a thread costs
/// more than it saves).
pub const PARALLEL_OBSERVE_MIN: usize = 64;
/// Robots a thread of [`World::observe_then`] takes at a time.
pub const OBSERVE_CHUNK: usize = 32;
/// One piece of [`World::observe_then`]'s work: observation slots, their noise streams and
/// items.
type Chunk<'a, T> = (Option<&'a mut [Observation]>, &'a mut [Rng], &'a mut [T]);
/// Most threads [`World::observe`] uses.
pub const OBSERVE_THREADS: usize = 4;

/// Threads to split `n` robots over: one below `min` robots, else one per core up to
/// [`OBSERVE_THREADS`] (shared by observing here and thinking in the in-process loop).
pub fn worker_threads(n: usize, min: usize) -> usize {
    if n < min {
        return 1;
    }
    std::thread::available_parallelism()
        .map(|p| p.get())
        .unwrap_or(1)
        .min(OBSERVE_THREADS)
}

/// What one observation reads: shared by every robot of a tick.
struct ObserveCtx<'a> {
    robots: &'a [Robot],
    map: &'a Map,
    grid: &'a Grid,
    radio: &'a RadioMedium,
    /// `lidar.ray_angle(k)` for each ray, worked out once per tick.
    ray_angles: Vec<f64>,
    tick: u64,
    lidar: &'a swarmrt_scenario::LidarConfig,
    rb_range: f64,
    radius: f64,
    reach: f64,
    /// [`reach_sq`] of `reach`.
    reach_sq: f64,
    noise: swarmrt_scenario::NoiseConfig,
    /// For each robot's goal ([`swarmrt_scenario::Config::goal_of`]).
    cfg: &'a swarmrt_scenario::Config,
    goal_sensor: swarmrt_scenario::GoalSensorConfig,
}

impl ObserveCtx<'_> {
    fn observe_one(&self, i: usize, o: &mut Observation, rng: &mut Rng, scratch: &mut Scratch) {
        let Scratch {
            near,
            picked,
            bodies,
            spare,
            counts,
        } = scratch;
        let (lidar, rb_range, radius, reach) = (self.lidar, self.rb_range, self.radius, self.reach);
        let (noise, goal_sensor) = (self.noise, self.goal_sensor);
        let goal = self.cfg.goal_of(i as u32);
        let r = &self.robots[i];
        // The fields of `Observation::empty`, the arrays left as they are: what this fills is
        // written below, the rest is cleared by `clear_unused` (writing the ~6 KB of an empty
        // observation first was a tenth of the sensing stage at 10,000 robots).
        set_empty_header(o, i as u32, self.tick);
        o.state = r.state as u8;
        o.reached = r.reached_tick.is_some() as u8;
        o.x = r.x + gauss(rng, noise.pose);
        o.y = r.y + gauss(rng, noise.pose);
        o.theta = wrap_angle(r.theta + gauss(rng, noise.heading));
        if self.cfg.robots.aerial.is_some() {
            // Drawn after x, y and theta, so ground runs consume the same stream as before.
            o.z = r.z + gauss(rng, noise.pose);
        }
        if r.state != RobotState::Active {
            return;
        }
        near.clear();
        // Most candidates of the grid lie outside the disc: their squared distance, a hair
        // above reach^2 (see `reach_sq`), rules them out without a square root. The distance
        // of those kept is the same expression as ever.
        let reach_sq = self.reach_sq;
        self.grid.near_points((r.x, r.y), reach, |j, (qx, qy)| {
            let d_sq = (qx - r.x).powi(2) + (qy - r.y).powi(2);
            if d_sq <= reach_sq && j != i {
                let d = d_sq.sqrt();
                if d <= reach {
                    near.push((d, j as u32));
                }
            }
        });
        // Distances are finite and non-negative here (NaN fails `d <= reach`), so their bits
        // order as the floats do: integer keys sort the same as `total_cmp`, faster. Only
        // what each sensor uses is sorted: the bodies within lidar reach, and the nearest
        // MAX_NEIGHBOURS emitters (a robot in a dense flock has hundreds within 1.5 m).
        let by_distance = |&(d, j): &(f64, u32)| (d.to_bits(), j);
        if r.lidar_on {
            let rays = (lidar.rays as usize).min(MAX_LIDAR_RAYS);
            // Other robots' bodies (in any state) are obstacles too. Bodies first, nearest
            // first: a ray stops looking once a body's nearest point lies beyond its best hit,
            // and the map is then asked only up to that hit (the hit distance is the same
            // whatever the limit; in a crowd most rays end on a neighbour well before a wall).
            picked.clear();
            picked.extend(
                near.iter()
                    .filter(|&&(dc, _)| dc - radius <= lidar.range + LIDAR_SKIP_MARGIN),
            );
            sort_by_distance(picked, reach, spare, counts);
            bodies.clear();
            bodies.extend(picked.iter().map(|&(dc, j)| {
                let q = &self.robots[j as usize];
                Body::new((r.x, r.y), (q.x, q.y), radius, dc)
            }));
            let (mut clearance, mut clear_bound) = (None, None);
            for k in 0..rays {
                let angle = r.theta + self.ray_angles[k];
                let dir = (angle.cos(), angle.sin());
                let mut d = lidar.range;
                for body in bodies.iter() {
                    // Any hit on this body is at least dc - radius away (exact to far below
                    // the margin), so neither it nor a farther body can lower d; d is a
                    // minimum, so the order of the bodies does not change it.
                    if body.near_edge > d + LIDAR_SKIP_MARGIN {
                        break;
                    }
                    if let Some(t) = body.hit(dir) {
                        d = d.min(t);
                    }
                }
                // A map hit is at least the robot's clearance away (up to rounding far below
                // the margin), so a ray already stopped nearer cannot find one: the cast
                // would say None. In a crowd most rays end on a neighbour. The cached bound of
                // the clearance settles most rays without asking the map at all.
                let bound =
                    *clear_bound.get_or_insert_with(|| self.map.clearance_bound((r.x, r.y)));
                if d + LIDAR_SKIP_MARGIN >= bound
                    && d + LIDAR_SKIP_MARGIN
                        >= *clearance.get_or_insert_with(|| self.map.clearance((r.x, r.y)))
                    && let Some(t) = self.map.cast_dir((r.x, r.y), dir, d)
                {
                    d = d.min(t);
                }
                let d = (d + gauss(rng, noise.lidar)).clamp(0.0, lidar.range);
                o.lidar[k] = d;
            }
            o.lidar_len = rays as u16;
        }
        // Range-and-bearing: the nearest MAX_NEIGHBOURS other robots with their emitter on,
        // nearest first. When the lidar already sorted everything within reach, that list
        // serves; otherwise select the nearest, then sort only those.
        let sorted_all = r.lidar_on && picked.len() == near.len();
        if sorted_all {
            picked.retain(|&(d, j)| {
                d <= rb_range && self.robots[j as usize].state == RobotState::Active
            });
            picked.truncate(MAX_NEIGHBOURS);
        } else {
            picked.clear();
            picked.extend(near.iter().filter(|&&(d, j)| {
                d <= rb_range && self.robots[j as usize].state == RobotState::Active
            }));
            if picked.len() > MAX_NEIGHBOURS {
                picked.select_nth_unstable_by_key(MAX_NEIGHBOURS - 1, by_distance);
                picked.truncate(MAX_NEIGHBOURS);
            }
            picked.sort_unstable_by_key(by_distance);
        }
        let mut seen = 0;
        for &(d, j) in picked.iter() {
            let q = &self.robots[j as usize];
            o.neighbours[seen] = Neighbour {
                id: j,
                range: d,
                bearing: wrap_angle((q.y - r.y).atan2(q.x - r.x) - r.theta),
            };
            seen += 1;
        }
        o.neighbours_len = seen as u16;
        let gd = ((goal.x - r.x).powi(2) + (goal.y - r.y).powi(2)).sqrt();
        let gb = wrap_angle((goal.y - r.y).atan2(goal.x - r.x) - r.theta);
        // With occlusion, the goal hides behind any obstacle between the robot and its edge.
        let hidden = || {
            let edge = (gd - goal.radius).max(0.0);
            let angle = (goal.y - r.y).atan2(goal.x - r.x);
            edge > 0.0 && self.map.cast((r.x, r.y), angle, edge).is_some()
        };
        if gd <= goal_sensor.range
            && gb.abs() <= goal_sensor.fov_deg.to_radians() / 2.0
            && !(goal_sensor.occlusion && hidden())
        {
            o.goal_visible = 1;
            o.goal_range = gd;
            o.goal_bearing = gb;
        }
        let inbox = self.radio.inbox(i);
        o.inbox_len = inbox.len().min(MAX_INBOX) as u16;
        for (slot, f) in inbox.take(MAX_INBOX).enumerate() {
            o.inbox[slot] = *f;
        }
    }
}

/// Sets every field but the arrays to what [`Observation::empty`] has.
fn set_empty_header(o: &mut Observation, robot: u32, tick: u64) {
    let e = Observation::empty(robot, tick);
    // Listed in full so that a new field cannot be missed.
    let Observation {
        version,
        robot,
        tick,
        state,
        reached,
        goal_visible,
        lidar_len,
        neighbours_len,
        inbox_len,
        x,
        y,
        theta,
        z,
        goal_range,
        goal_bearing,
        lidar: _,
        neighbours: _,
        inbox: _,
    } = o;
    (*version, *robot, *tick) = (e.version, e.robot, e.tick);
    (*state, *reached, *goal_visible) = (e.state, e.reached, e.goal_visible);
    (*lidar_len, *neighbours_len, *inbox_len) = (e.lidar_len, e.neighbours_len, e.inbox_len);
    (*x, *y, *theta, *z) = (e.x, e.y, e.theta, e.z);
    (*goal_range, *goal_bearing) = (e.goal_range, e.goal_bearing);
}

/// Resets each array past its length to what [`Observation::empty`] has there, so that the
/// observation is the same bytes as one built from empty, whatever the slot held before.
fn clear_unused(o: &mut Observation) {
    o.lidar[(o.lidar_len as usize).min(MAX_LIDAR_RAYS)..].fill(0.0);
    o.neighbours[(o.neighbours_len as usize).min(MAX_NEIGHBOURS)..].fill(Neighbour::EMPTY);
    o.inbox[(o.inbox_len as usize).min(MAX_INBOX)..].fill(Frame::EMPTY);
}

/// A bound on squared distances within `reach`: `sqrt(d_sq) <= reach` implies
/// `d_sq <= reach_sq(reach)` (a correctly rounded square root at or below `reach` comes from a
/// `d_sq` at most an ulp or so above `reach^2`; the bound leaves 1e-9 relative). Infinite,
/// which rules nothing out, where `reach^2` would lose precision.
fn reach_sq(reach: f64) -> f64 {
    let sq = reach * reach * (1.0 + 1e-9);
    if reach >= 1e-100 && sq.is_finite() {
        sq
    } else {
        f64::INFINITY
    }
}

/// Metres a robot body's nearest point must lie beyond a ray's best hit before the ray stops
/// testing bodies (rounding in [`Body::hit`] is ~1e-15 m at these distances).
const LIDAR_SKIP_MARGIN: f64 = 1e-9;

/// One thread's buffers for [`ObserveCtx::observe_one`], kept from robot to robot.
#[derive(Default)]
struct Scratch {
    /// Other robots within reach: (centre distance, id), in grid order.
    near: Vec<(f64, u32)>,
    /// The part of `near` one sensor uses, sorted nearest first.
    picked: Vec<(f64, u32)>,
    /// The lidar's bodies, nearest first.
    bodies: Vec<Body>,
    /// Scratch of [`sort_by_distance`].
    spare: Vec<(f64, u32)>,
    /// Scratch of [`sort_by_distance`].
    counts: Vec<u32>,
}

/// Sorts `v` by (distance, id), as `sort_unstable_by_key` with `(d.to_bits(), id)` does (the
/// same order: ids are distinct), for distances in `[0, reach]`. Bucketed first by `d^2` (a
/// robot's neighbours spread evenly over the disc's area, so about one per bucket; the
/// bucket never decreases as `d` grows, rounding included), then each bucket sorted: O(n)
/// instead of O(n log n) for the ~60 robots within lidar reach in a crowd.
fn sort_by_distance(
    v: &mut Vec<(f64, u32)>,
    reach: f64,
    spare: &mut Vec<(f64, u32)>,
    counts: &mut Vec<u32>,
) {
    let by_distance = |&(d, j): &(f64, u32)| (d.to_bits(), j);
    let n = v.len();
    let scale = n as f64 / (reach * reach);
    if n < 16 || !(scale.is_finite() && scale > 0.0) {
        v.sort_unstable_by_key(by_distance);
        return;
    }
    let bucket = |d: f64| ((d * d * scale) as usize).min(n - 1);
    counts.clear();
    counts.resize(n + 1, 0);
    for &(d, _) in v.iter() {
        counts[bucket(d) + 1] += 1;
    }
    for b in 1..=n {
        counts[b] += counts[b - 1];
    }
    spare.clear();
    spare.resize(n, (0.0, 0));
    for &e in v.iter() {
        let b = bucket(e.0);
        spare[counts[b] as usize] = e;
        counts[b] += 1;
    }
    // counts[b] is now the end of bucket b (and the start of bucket b + 1).
    let mut start = 0;
    for &end in &counts[..n] {
        let end = end as usize;
        if end - start > 1 {
            spare[start..end].sort_unstable_by_key(by_distance);
        }
        start = end;
    }
    std::mem::swap(v, spare);
}

/// Another robot's body as the lidar rays of one robot see it: the parts of the ray-circle
/// test that do not depend on the ray, worked out once for all rays (same arithmetic, same
/// bits as doing it per ray), packed so the inner loop reads 32 contiguous bytes per body.
struct Body {
    /// Ray origin minus circle centre.
    f: (f64, f64),
    /// |f|^2 - r^2.
    cc: f64,
    /// Centre distance minus radius: no hit on this body is nearer.
    near_edge: f64,
}

impl Body {
    fn new(o: (f64, f64), c: (f64, f64), r: f64, dc: f64) -> Body {
        let (fx, fy) = (o.0 - c.0, o.1 - c.1);
        Body {
            f: (fx, fy),
            cc: fx * fx + fy * fy - r * r,
            near_edge: dc - r,
        }
    }

    /// Distance along the ray from the robot in unit direction `dir` (cos, sin of its
    /// angle) to this body, if it hits ahead.
    fn hit(&self, dir: (f64, f64)) -> Option<f64> {
        let b = self.f.0 * dir.0 + self.f.1 * dir.1;
        circle_root(b, b * b - self.cc)
    }
}

/// The nearer root `t >= 0` of `t^2 + 2bt + cc = 0` given its discriminant, or 0 when the ray
/// starts inside the circle.
fn circle_root(b: f64, disc: f64) -> Option<f64> {
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t = -b - s;
    if t >= 0.0 {
        Some(t)
    } else if -b + s >= 0.0 {
        Some(0.0)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sort_by_distance_orders_as_the_comparison_sort() {
        let mut spare = Vec::new();
        let mut counts = Vec::new();
        let mut seed = 7u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for n in [0, 1, 5, 15, 16, 17, 60, 300] {
            for reach in [0.5, 3.15, 40.0] {
                // Distances in [0, reach], some repeated, some at the ends, in any id order.
                let mut v: Vec<(f64, u32)> = (0..n as u32)
                    .map(|j| {
                        let d = match next() % 8 {
                            0 => 0.0,
                            1 => reach,
                            2 => reach * 0.5,
                            _ => reach * (next() % 1_000_001) as f64 / 1e6,
                        };
                        (d, j * 7 % 1009)
                    })
                    .collect();
                let mut want = v.clone();
                want.sort_unstable_by_key(|&(d, j)| (d.to_bits(), j));
                sort_by_distance(&mut v, reach, &mut spare, &mut counts);
                let bits =
                    |v: &[(f64, u32)]| v.iter().map(|&(d, j)| (d.to_bits(), j)).collect::<Vec<_>>();
                assert_eq!(bits(&v), bits(&want), "n {n} reach {reach}");
            }
        }
    }
}
