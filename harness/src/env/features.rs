//! What a policy sees of one observation: the fields of [`Observation`] a robot process gets,
//! cut to fixed sizes (the first `neighbours` neighbours, the first `inbox` opaque frames of
//! `payload` bytes) with masks, so that a batch of robots is a set of dense arrays. The
//! learning environment and a policy deployed as a robot process both call [`Features::fill`],
//! so a policy sees the same numbers in both.

use swarmrt_protocol::{MAX_INBOX, MAX_NEIGHBOURS, MAX_PAYLOAD, Observation};
use swarmrt_scenario::Config;

/// The fixed sizes of a policy's view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Lidar rays (the config's `robots.lidar.rays`).
    pub rays: usize,
    /// Neighbours kept, nearest first (at most [`MAX_NEIGHBOURS`]).
    pub neighbours: usize,
    /// Opaque radio frames kept per tick, in delivery order (at most [`MAX_INBOX`]).
    pub inbox: usize,
    /// Bytes kept of each frame, and the most a policy may say in one (at most
    /// [`MAX_PAYLOAD`] - 1: the opaque tag takes one byte).
    pub payload: usize,
}

impl Layout {
    /// The layout for `cfg`'s robots, or the bound that a size breaks.
    pub fn new(
        cfg: &Config,
        neighbours: usize,
        inbox: usize,
        payload: usize,
    ) -> Result<Layout, String> {
        let bound = |name: &str, v: usize, max: usize| {
            if v > max {
                Err(format!("{name} = {v} is out of range: at most {max}"))
            } else {
                Ok(())
            }
        };
        bound("neighbours", neighbours, MAX_NEIGHBOURS)?;
        bound("inbox", inbox, MAX_INBOX)?;
        bound("payload", payload, MAX_PAYLOAD - 1)?;
        Ok(Layout {
            rays: cfg.robots.lidar.rays as usize,
            neighbours,
            inbox,
            payload,
        })
    }
}

/// A batch of robots' views, one dense array per field, robot after robot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Features {
    /// Estimated x, y (m) and heading (rad): 3 per robot.
    pub pose: Vec<f32>,
    /// Goal seen (0 or 1), its range (m) and bearing (rad) when seen: 3 per robot.
    pub goal: Vec<f32>,
    /// Lidar ranges (m), `rays` per robot; the maximum range where nothing was hit or the
    /// lidar was off this tick.
    pub lidar: Vec<f32>,
    /// Range (m) and bearing (rad) of each kept neighbour: `neighbours` x 2 per robot.
    pub neighbours: Vec<f32>,
    /// 1 where a neighbour slot holds one: `neighbours` per robot.
    pub neighbours_mask: Vec<u8>,
    /// The bytes of each kept opaque frame, zero-padded: `inbox` x `payload` per robot.
    pub inbox: Vec<u8>,
    /// Each kept frame's sender and its length in bytes: `inbox` x 2 per robot.
    pub inbox_meta: Vec<i32>,
    /// 1 where an inbox slot holds a frame: `inbox` per robot.
    pub inbox_mask: Vec<u8>,
}

impl Features {
    /// Room for `robots` robots of `layout`, all zero.
    pub fn zeroed(layout: &Layout, robots: usize) -> Features {
        Features {
            pose: vec![0.0; robots * 3],
            goal: vec![0.0; robots * 3],
            lidar: vec![0.0; robots * layout.rays],
            neighbours: vec![0.0; robots * layout.neighbours * 2],
            neighbours_mask: vec![0; robots * layout.neighbours],
            inbox: vec![0; robots * layout.inbox * layout.payload],
            inbox_meta: vec![0; robots * layout.inbox * 2],
            inbox_mask: vec![0; robots * layout.inbox],
        }
    }

    /// Writes robot slot `i`'s view of `o` (the lidar's maximum range `max_range` where `o`
    /// holds no reading).
    pub fn fill(&mut self, layout: &Layout, i: usize, o: &Observation, max_range: f64) {
        self.pose[i * 3..i * 3 + 3].copy_from_slice(&[o.x as f32, o.y as f32, o.theta as f32]);
        let seen = o.goal_visible != 0;
        self.goal[i * 3..i * 3 + 3].copy_from_slice(&if seen {
            [1.0, o.goal_range as f32, o.goal_bearing as f32]
        } else {
            [0.0; 3]
        });
        let lidar = &mut self.lidar[i * layout.rays..(i + 1) * layout.rays];
        let read = (o.lidar_len as usize).min(o.lidar.len());
        for (k, slot) in lidar.iter_mut().enumerate() {
            *slot = if k < read { o.lidar[k] } else { max_range } as f32;
        }
        let k = layout.neighbours;
        let seen = (o.neighbours_len as usize).min(o.neighbours.len());
        for j in 0..k {
            let (range, bearing, mask) = match o.neighbours.get(j).filter(|_| j < seen) {
                Some(n) => (n.range as f32, n.bearing as f32, 1),
                None => (0.0, 0.0, 0),
            };
            self.neighbours[(i * k + j) * 2] = range;
            self.neighbours[(i * k + j) * 2 + 1] = bearing;
            self.neighbours_mask[i * k + j] = mask;
        }
        let (m, p) = (layout.inbox, layout.payload);
        self.inbox[i * m * p..(i + 1) * m * p].fill(0);
        self.inbox_meta[i * m * 2..(i + 1) * m * 2].fill(0);
        self.inbox_mask[i * m..(i + 1) * m].fill(0);
        let frames = &o.inbox[..(o.inbox_len as usize).min(o.inbox.len())];
        let opaque = frames
            .iter()
            .filter_map(|f| f.opaque_bytes().map(|b| (f.src, b)));
        for (j, (src, bytes)) in opaque.take(m).enumerate() {
            let kept = &bytes[..bytes.len().min(p)];
            let at = (i * m + j) * p;
            self.inbox[at..at + kept.len()].copy_from_slice(kept);
            self.inbox_meta[(i * m + j) * 2] = src as i32;
            self.inbox_meta[(i * m + j) * 2 + 1] = bytes.len() as i32;
            self.inbox_mask[i * m + j] = 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmrt_protocol::{BROADCAST, Frame, Neighbour};

    fn layout() -> Layout {
        Layout {
            rays: 4,
            neighbours: 2,
            inbox: 2,
            payload: 3,
        }
    }

    #[test]
    fn a_view_keeps_the_first_slots_masks_the_rest_and_skips_postcard_frames() {
        let mut o = Observation::empty(0, 5);
        o.x = 1.5;
        o.lidar_len = 2;
        o.lidar[..2].copy_from_slice(&[0.5, 0.7]);
        o.neighbours_len = 1;
        o.neighbours[0] = Neighbour {
            id: 3,
            range: 0.9,
            bearing: -1.0,
        };
        o.inbox_len = 3;
        o.inbox[0] = Frame::opaque(BROADCAST, b"abcd").unwrap();
        o.inbox[0].src = 4;
        o.inbox[1].len = 2; // a postcard frame: not for a policy
        o.inbox[2] = Frame::opaque(BROADCAST, b"z").unwrap();
        o.inbox[2].src = 6;
        let mut f = Features::zeroed(&layout(), 2);
        f.fill(&layout(), 1, &o, 2.0);
        assert_eq!(&f.pose[3..6], &[1.5, 0.0, 0.0]);
        assert_eq!(&f.lidar[4..8], &[0.5, 0.7, 2.0, 2.0]);
        assert_eq!(&f.neighbours[4..8], &[0.9, -1.0, 0.0, 0.0]);
        assert_eq!(&f.neighbours_mask[2..4], &[1, 0]);
        assert_eq!(&f.inbox[6..12], b"abcz\0\0", "cut to 3 bytes, padded");
        assert_eq!(
            &f.inbox_meta[4..8],
            &[4, 4, 6, 1],
            "sender and whole length"
        );
        assert_eq!(&f.inbox_mask[2..4], &[1, 1]);
        assert!(f.pose[..3].iter().all(|&v| v == 0.0), "slot 0 untouched");
    }

    #[test]
    fn sizes_past_the_protocol_are_refused_with_the_bound() {
        let cfg = swarmrt_agent::registry::from_toml_str(
            "t.toml",
            "[scenario]\nname = \"t\"\nticks = 5\n[map]\nbounds = [0.0, 0.0, 5.0, 5.0]\ngoal = { x = 4.0, y = 4.0, radius = 0.5 }\n[robots]\ncount = 1\n",
            &[],
        )
        .unwrap();
        let e = Layout::new(&cfg, 99, 1, 1).unwrap_err();
        assert_eq!(e, "neighbours = 99 is out of range: at most 32");
        assert!(Layout::new(&cfg, 1, 1, MAX_PAYLOAD).is_err());
    }
}
