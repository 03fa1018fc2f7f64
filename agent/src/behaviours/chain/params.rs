//! `[behaviour]` of `kind = "chain"`: the rods and connectors of section 3 (Table 1), the
//! head's wall distances of section 3 "Exploratory behaviour" (0.7 and 0.9 m), and the
//! choices the paper leaves open (how a master's motion reaches its slave, how long a veto
//! lasts, how a head re-plans).

use serde::{Deserialize, Serialize};
use swarmrt_scenario::reference::{Bounds, Key, Lim, check_f, check_u, hi, k, lo, r};
use swarmrt_scenario::validate::{check, range_f, range_u64, short};
use swarmrt_scenario::{Config, KeyError};

use crate::behaviour::Params;

/// Where a slave learns its master's position (the issue asks us to choose; both are
/// measured in `docs/results/seed003.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MasterFrom {
    /// Its own range-and-bearing sensor (section 2: "using vision"); no loss, no delay, one
    /// tick per hop because the slave sees its master only after the master moved.
    Rab,
    /// The master's radio `Link` frames only: `1 + radio.delay_ticks` ticks per hop, and a
    /// lost frame leaves the slave with an older position.
    Radio,
    /// Range-and-bearing when the master is in view, else its latest radio frame.
    Both,
}

/// How a slave whose guiding line is blocked rotates its rod (Push-Pull-Rotate, Fig. 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rotate {
    /// Towards the newest point of its master's trail it can reach in a straight line: where
    /// the master has been is collision free by construction, and no randomness is needed.
    Trail,
    /// Appendix A's `ROTATE`: shake the colliding position at random (from the run seed's
    /// stream) until the guiding line from the master is collision free.
    Shake,
}

/// Parameters of the chain behaviour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChainParams {
    /// Rod MinLength in metres (Table 1): closer than this, the master pushes its slave.
    pub rod_min: f64,
    /// Rod MaxLength in metres: farther than this, the master pulls its slave.
    pub rod_max: f64,
    /// Connector MinAngle in degrees: the angle at a robot between its two chain neighbours
    /// (180 = straight) is kept at least this.
    pub angle_min_deg: f64,
    /// Connector MaxAngle in degrees.
    pub angle_max_deg: f64,
    /// Metres a rod may be outside `[rod_min, rod_max]` before `chain.rod_violations` counts
    /// it (a slave process sees its master one tick late, so some excess is physics).
    pub rod_tolerance: f64,
    /// Degrees a connector may be outside its angle limits before `chain.angle_violations`
    /// counts it.
    pub angle_tolerance_deg: f64,
    /// The robot that initiates the motion (section 3: "any part of the chain ... can
    /// initiate"); the chain is then two sub-chains headed by it (Fig. 3).
    pub initiator: u32,
    /// Stationary (fixed) robots: they never move and veto any relocation (Fig. 3).
    pub stationary: Vec<u32>,
    /// s of Table 2: the initiator's wheel speed in m/s (at most `robots.max_speed`; the
    /// other robots may use the full `robots.max_speed` to keep up).
    pub speed: f64,
    /// Axle length in metres, turning Table 2's wheel speeds into a turn rate.
    pub axle: f64,
    /// Minimum wall distance of the wall following in metres (0.7 in the paper).
    pub wall_min: f64,
    /// Maximum wall distance in metres (0.9 in the paper).
    pub wall_max: f64,
    /// The side sectors `[from, to]` in degrees off the heading: the left-front reading is
    /// the nearest lidar hit in `[from, to]`, the right-front one in `[-to, -from]`.
    pub side_sector_deg: [f64; 2],
    /// Gain of TARGET-CHECK's turn towards the target (per radian of bearing).
    pub target_gain: f64,
    /// The initiator stops for good once it has reached the target; otherwise it passes
    /// through and keeps wall following, so the whole chain threads the target.
    pub stop_at_target: bool,
    /// Degrees the initiator turns in place after a veto reached it (its re-plan), towards
    /// the side with more room.
    pub replan_turn_deg: f64,
    /// Where a slave learns its master's position.
    pub master_from: MasterFrom,
    /// Master positions a slave remembers (its trail, for Push-Pull-Rotate, Fig. 5).
    pub trail: u32,
    /// Metres of clearance beyond `robots.radius` a guiding line needs from any lidar hit to
    /// count as collision free.
    pub line_clearance: f64,
    /// Ticks a slave may find no collision-free guiding line before it vetoes (trapped).
    pub trapped_ticks: u32,
    /// Ticks a heard veto keeps holding (the veto is repeated every tick while it lasts, so
    /// this rides over lost frames).
    pub veto_hold: u32,
    /// Turn gain of a robot steering to its target point (rad/s per radian).
    pub turn_gain: f64,
    /// How a blocked rod rotates: the master's trail, or Appendix A's random shake.
    pub rotate: Rotate,
    /// Shakes a slave tries per tick before it counts the tick as trapped (`rotate = "shake"`).
    pub shake_tries: u32,
}

impl Default for ChainParams {
    fn default() -> Self {
        ChainParams {
            rod_min: 0.3,
            rod_max: 0.45,
            angle_min_deg: 90.0,
            angle_max_deg: 180.0,
            rod_tolerance: 0.05,
            angle_tolerance_deg: 10.0,
            initiator: 0,
            stationary: Vec::new(),
            speed: 0.2,
            axle: 0.2,
            wall_min: 0.7,
            wall_max: 0.9,
            side_sector_deg: [15.0, 90.0],
            target_gain: 1.0,
            stop_at_target: false,
            replan_turn_deg: 90.0,
            master_from: MasterFrom::Both,
            trail: 64,
            line_clearance: 0.15,
            trapped_ticks: 20,
            veto_hold: 3,
            turn_gain: 3.0,
            rotate: Rotate::Trail,
            shake_tries: 64,
        }
    }
}

const BELOW_COUNT: Bounds = Bounds::Range(Lim::V(0.0), Lim::Of("robots.count - 1"));

impl Params for ChainParams {
    #[rustfmt::skip]
    const KEYS: &'static [Key] = &[
        k("behaviour.rod_min", Bounds::Range(Lim::Of("2 * robots.radius"), Lim::V(1e3)), "m", "Rod MinLength (Table 1): closer than this, the master pushes its slave."),
        k("behaviour.rod_max", Bounds::Range(Lim::Of("rod_min"), Lim::V(1e3)), "m", "Rod MaxLength: farther than this, the master pulls its slave."),
        k("behaviour.angle_min_deg", r(0.0, 180.0), "deg", "Connector MinAngle: the angle at a robot between its chain neighbours (180 = straight)."),
        k("behaviour.angle_max_deg", Bounds::Range(Lim::Of("angle_min_deg"), Lim::V(180.0)), "deg", "Connector MaxAngle."),
        k("behaviour.rod_tolerance", r(0.0, 1e3), "m", "How far a rod may be outside its limits before `chain.rod_violations` counts it."),
        k("behaviour.angle_tolerance_deg", r(0.0, 180.0), "deg", "How far a connector may be outside its limits before `chain.angle_violations` counts it."),
        k("behaviour.initiator", BELOW_COUNT, "", "The robot that initiates the motion; the chain is two sub-chains headed by it."),
        k("behaviour.stationary", BELOW_COUNT, "", "Fixed robots: they never move and veto any relocation.").also("not the initiator").ty("array of integer"),
        k("behaviour.speed", Bounds::Range(Lim::V(0.0), Lim::Of("robots.max_speed")), "m/s", "s of Table 2: the initiator's wheel speed (the others may use `robots.max_speed`)."),
        k("behaviour.axle", r(1e-4, 100.0), "m", "Axle length, turning Table 2's wheel speeds into a turn rate."),
        k("behaviour.wall_min", r(0.0, 1e3), "m", "Minimum wall distance of the wall following (the paper: 0.7)."),
        k("behaviour.wall_max", Bounds::Range(Lim::Of("wall_min"), Lim::V(1e3)), "m", "Maximum wall distance (the paper: 0.9)."),
        k("behaviour.side_sector_deg", r(0.0, 180.0), "deg", "`[from, to]` off the heading: the left-front sector (right-front: `[-to, -from]`).").also("from <= to"),
        k("behaviour.target_gain", r(0.0, 1e3), "1/rad", "Gain of TARGET-CHECK's turn towards the target."),
        k("behaviour.stop_at_target", Bounds::Any, "", "The initiator stops at the target; false: it passes through so the whole chain threads it."),
        k("behaviour.replan_turn_deg", r(0.0, 360.0), "deg", "The initiator's turn in place after a veto, towards the side with more room."),
        k("behaviour.master_from", Bounds::Any, "", "Where a slave learns its master's position: range-and-bearing, radio, or both."),
        k("behaviour.trail", r(1.0, 10_000.0), "", "Master positions a slave remembers (for Push-Pull-Rotate)."),
        k("behaviour.line_clearance", r(0.0, 1e3), "m", "Clearance beyond `robots.radius` a guiding line needs from any lidar hit."),
        k("behaviour.trapped_ticks", r(1.0, 1_000_000.0), "ticks", "Ticks a slave may find no clear guiding line before it vetoes."),
        k("behaviour.veto_hold", r(1.0, 1_000_000.0), "ticks", "Ticks a heard veto keeps holding (rides over lost frames)."),
        k("behaviour.turn_gain", r(0.0, 1e3), "1/s", "Turn gain of a robot steering to its target point (rad/s per radian)."),
        k("behaviour.rotate", Bounds::Any, "", "How a blocked rod rotates: towards the master's trail, or Appendix A's random shake of the colliding point."),
        k("behaviour.shake_tries", r(1.0, 100_000.0), "", "Shakes per tick before the tick counts as trapped (rotate = \"shake\")."),
    ];

    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        let keys = Self::KEYS;
        let (low, high) = (|key| lo(keys, key), |key| hi(keys, key));
        let r = &cfg.robots;
        let max_rod = high("behaviour.rod_min");
        range_f("behaviour.rod_min", self.rod_min, 2.0 * r.radius, max_rod).map_err(|(k, _)| {
            (
                k,
                format!(
                    "a length in [2 * robots.radius = {}, {}] so neighbours never touch, got {}",
                    short(2.0 * r.radius),
                    short(max_rod),
                    short(self.rod_min)
                ),
            )
        })?;
        range_f(
            "behaviour.rod_max",
            self.rod_max,
            self.rod_min,
            high("behaviour.rod_max"),
        )?;
        check_f(keys, "behaviour.angle_min_deg", self.angle_min_deg)?;
        range_f(
            "behaviour.angle_max_deg",
            self.angle_max_deg,
            self.angle_min_deg,
            high("behaviour.angle_max_deg"),
        )?;
        check_f(keys, "behaviour.rod_tolerance", self.rod_tolerance)?;
        check_f(
            keys,
            "behaviour.angle_tolerance_deg",
            self.angle_tolerance_deg,
        )?;
        let n = r.count.max(1);
        let first = low("behaviour.initiator") as u64;
        range_u64(
            "behaviour.initiator",
            self.initiator as u64,
            first,
            n as u64 - 1,
        )?;
        for (k, &s) in self.stationary.iter().enumerate() {
            range_u64(
                &format!("behaviour.stationary[{k}]"),
                s as u64,
                first,
                n as u64 - 1,
            )?;
            check(
                s != self.initiator,
                &format!("behaviour.stationary[{k}]"),
                "a robot other than behaviour.initiator (the initiator moves)",
            )?;
        }
        range_f(
            "behaviour.speed",
            self.speed,
            low("behaviour.speed"),
            r.max_speed,
        )?;
        check_f(keys, "behaviour.axle", self.axle)?;
        check_f(keys, "behaviour.wall_min", self.wall_min)?;
        range_f(
            "behaviour.wall_max",
            self.wall_max,
            self.wall_min,
            high("behaviour.wall_max"),
        )?;
        let [from, to] = self.side_sector_deg;
        check_f(keys, "behaviour.side_sector_deg[0]", from)?;
        range_f(
            "behaviour.side_sector_deg[1]",
            to,
            from,
            high("behaviour.side_sector_deg"),
        )?;
        check_f(keys, "behaviour.target_gain", self.target_gain)?;
        check_f(keys, "behaviour.replan_turn_deg", self.replan_turn_deg)?;
        check_u(keys, "behaviour.trail", self.trail as u64)?;
        check_f(keys, "behaviour.line_clearance", self.line_clearance)?;
        check_u(keys, "behaviour.trapped_ticks", self.trapped_ticks as u64)?;
        check_u(keys, "behaviour.veto_hold", self.veto_hold as u64)?;
        check_f(keys, "behaviour.turn_gain", self.turn_gain)?;
        check_u(keys, "behaviour.shake_tries", self.shake_tries as u64)?;
        Ok(())
    }
}
