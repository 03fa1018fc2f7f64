//! `VecEnv`: K worlds of [`swarmrt_harness::env::Env`] stepped together on threads with the
//! GIL released, their views and results as flat little arrays (bytes) that `swarmrt.env`
//! reshapes with numpy. A `parallel_env` is a `VecEnv` of one world.

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use swarmrt_harness::env::{Action, Env, EnvError, Features, Layout};
use swarmrt_protocol::{Command, Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::OutDir;

use crate::{ConfigError, SwarmrtError, run::load};

/// K independent worlds of one config, seeds `seed`, `seed + 1`, ...
#[pyclass(module = "swarmrt._native")]
pub struct VecEnv {
    cfg: Config,
    layout: Layout,
    envs: Vec<Env>,
    /// Each world's last step's events, as JSON lines.
    events: Vec<Vec<String>>,
}

fn env_error(e: EnvError) -> PyErr {
    match e {
        EnvError::Action(a) => pyo3::exceptions::PyValueError::new_err(a.to_string()),
        EnvError::Map(_) => ConfigError::new_err(e.to_string()),
        EnvError::Records(_) => SwarmrtError::new_err(e.to_string()),
    }
}

fn make(
    cfg: &Config,
    layout: Layout,
    seed: u64,
    record: Option<&std::path::Path>,
) -> PyResult<Env> {
    let mut cfg = cfg.clone();
    cfg.scenario.seed = seed;
    let dir =
        match record {
            Some(path) => Some(OutDir::create(path).map_err(|e| {
                SwarmrtError::new_err(format!("cannot make {}: {e}", path.display()))
            })?),
            None => None,
        };
    Env::new(&cfg, layout, dir.as_ref()).map_err(env_error)
}

#[pymethods]
impl VecEnv {
    #[new]
    #[pyo3(signature = (config, set, num_envs, seed=None, neighbours=8, inbox=4, payload=0))]
    fn new(
        config: &str,
        set: Vec<String>,
        num_envs: usize,
        seed: Option<u64>,
        neighbours: usize,
        inbox: usize,
        payload: usize,
    ) -> PyResult<VecEnv> {
        let cfg = load(config, &set)?;
        if cfg.robots.aerial.is_some() {
            return Err(ConfigError::new_err(format!(
                "{config}: robots.aerial: the learning environment drives ground robots (v, omega) only"
            )));
        }
        if !(1..=4096).contains(&num_envs) {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "num_envs = {num_envs} is out of range [1, 4096]"
            )));
        }
        let layout = Layout::new(&cfg, neighbours, inbox, payload)
            .map_err(pyo3::exceptions::PyValueError::new_err)?;
        let base = seed.unwrap_or(cfg.scenario.seed);
        let mut env = VecEnv {
            envs: Vec::with_capacity(num_envs),
            events: vec![Vec::new(); num_envs],
            cfg,
            layout,
        };
        for k in 0..num_envs {
            env.envs
                .push(make(&env.cfg, layout, base + k as u64, None)?);
        }
        Ok(env)
    }

    /// Number of worlds.
    #[getter]
    fn num_envs(&self) -> usize {
        self.envs.len()
    }

    /// Robots per world.
    #[getter]
    fn num_agents(&self) -> usize {
        self.cfg.robots.count as usize
    }

    /// The sizes of a view: rays, neighbours, inbox frames, payload bytes.
    #[getter]
    fn layout(&self) -> (usize, usize, usize, usize) {
        let l = self.layout;
        (l.rays, l.neighbours, l.inbox, l.payload)
    }

    /// The limits of an action and of a reading: max speed, max turn rate, lidar range, the
    /// map's bounds, the run's ticks.
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let r = &self.cfg.robots;
        d.set_item("max_speed", r.max_speed)?;
        d.set_item("max_turn_rate", r.max_turn_rate)?;
        d.set_item("lidar_range", r.lidar.range)?;
        d.set_item("bounds", self.cfg.map.bounds.to_vec())?;
        d.set_item("ticks", self.cfg.scenario.ticks)?;
        d.set_item("scenario", self.cfg.scenario.name.clone())?;
        d.set_item("seed", self.cfg.scenario.seed)?;
        Ok(d)
    }

    /// Rebuilds world `k` at tick 0 with `seed`, recording its run into the directory
    /// `record` when given (`trajectory.csv`, `events.jsonl`, as `swarm run` writes them).
    #[pyo3(signature = (k, seed, record=None))]
    fn reset_one(
        &mut self,
        k: usize,
        seed: u64,
        record: Option<std::path::PathBuf>,
    ) -> PyResult<()> {
        if k >= self.envs.len() {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "world {k} of {}",
                self.envs.len()
            )));
        }
        self.envs[k] = make(&self.cfg, self.layout, seed, record.as_deref())?;
        self.events[k].clear();
        Ok(())
    }

    /// Every world's current views, robot after robot, world after world: a dict of bytes
    /// (float32 or uint8 or int32, by field).
    fn observe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let n = self.num_agents();
        let mut f = Features::zeroed(&self.layout, n * self.envs.len());
        py.detach(|| {
            for (k, env) in self.envs.iter().enumerate() {
                env.features_into(&mut f, k * n);
            }
        });
        features_dict(py, &f)
    }

    /// The worlds' truth per robot: x, y, theta, v, omega (float64) and state (uint8: 0
    /// active, 1 frozen, 2 down, 3 dead, 4 restarting), and the tick of each world.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let robots = || self.envs.iter().flat_map(|e| e.world().robots());
        let col = |f: &dyn Fn(&swarmrt_world::world::Robot) -> f64| -> Vec<f64> {
            robots().map(f).collect()
        };
        let d = PyDict::new(py);
        d.set_item("x", f64_bytes(py, &col(&|r| r.x)))?;
        d.set_item("y", f64_bytes(py, &col(&|r| r.y)))?;
        d.set_item("theta", f64_bytes(py, &col(&|r| r.theta)))?;
        d.set_item("v", f64_bytes(py, &col(&|r| r.v)))?;
        d.set_item("omega", f64_bytes(py, &col(&|r| r.omega)))?;
        let states: Vec<u8> = robots().map(|r| r.state as u8).collect();
        d.set_item("state", PyBytes::new(py, &states))?;
        let ticks: Vec<u64> = self.envs.iter().map(|e| e.world().tick()).collect();
        d.set_item("tick", ticks)?;
        Ok(d)
    }

    /// True per robot (world after world) where the robot answers this tick.
    fn expects<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let n = self.num_agents();
        let v: Vec<u8> = (self.envs.iter())
            .flat_map(|e| (0..n).map(|r| e.expects_action(r) as u8))
            .collect();
        PyBytes::new(py, &v)
    }

    /// Steps every world with its robots' actions: `v` and `omega` (float64, one per robot,
    /// world after world), `say` (uint8, `payload` per robot) and `say_len` (uint8, one per
    /// robot: how many of its bytes to broadcast). Returns rewards (float64 per robot),
    /// terminated (uint8 per robot) and truncated (uint8 per world). Every action is checked
    /// before any world moves: a refused one raises ValueError naming the world, the robot
    /// and the bound.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        v: &[u8],
        omega: &[u8],
        say: &[u8],
        say_len: &[u8],
    ) -> PyResult<(
        Bound<'py, PyBytes>,
        Bound<'py, PyBytes>,
        Bound<'py, PyBytes>,
    )> {
        let n = self.num_agents();
        let total = n * self.envs.len();
        let p = self.layout.payload;
        let (v, omega) = (f64s(v, total, "v")?, f64s(omega, total, "omega")?);
        if say.len() != total * p || say_len.len() != total {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "say must hold {} bytes and say_len {total}",
                total * p
            )));
        }
        let actions: Vec<Action> = (0..total)
            .map(|i| Action {
                v: v[i],
                omega: omega[i],
                say: say[i * p..i * p + (say_len[i] as usize).min(p + 1)].to_vec(),
            })
            .collect();
        let cfg = &self.cfg;
        for (k, env) in self.envs.iter().enumerate() {
            for r in (0..n).filter(|&r| env.expects_action(r)) {
                actions[k * n + r].check(cfg, r as u32, p).map_err(|e| {
                    pyo3::exceptions::PyValueError::new_err(format!("world {k}: {e}"))
                })?;
            }
        }
        // A panic in a world stays on this side: the worlds are then in no state to go on.
        let outcomes = py
            .detach(|| {
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    step_all(&mut self.envs, &actions, n)
                }))
            })
            .map_err(|p| {
                SwarmrtError::new_err(format!(
                    "internal error in a world's step: {}; reset the environment",
                    crate::run::panic_message(&p)
                ))
            })?;
        let mut rewards = Vec::with_capacity(total);
        let mut terminated = Vec::with_capacity(total);
        let mut truncated = Vec::with_capacity(self.envs.len());
        for (k, outcome) in outcomes.into_iter().enumerate() {
            let o = outcome.map_err(env_error)?;
            rewards.extend(o.rewards);
            terminated.extend(o.terminated.iter().map(|&t| t as u8));
            truncated.push(o.truncated as u8);
            self.events[k] = (o.events.iter())
                .filter_map(|e| serde_json::to_string(e).ok())
                .collect();
        }
        Ok((
            f64_bytes(py, &rewards),
            PyBytes::new(py, &terminated),
            PyBytes::new(py, &truncated),
        ))
    }

    /// World `k`'s events of the last step, as JSON lines (the `events.jsonl` vocabulary).
    fn events(&self, k: usize) -> Vec<String> {
        self.events.get(k).cloned().unwrap_or_default()
    }
}

/// Steps each world with its slice of `actions`, on rayon's pool (threads that stay up
/// between steps: spawning two threads a step cost more than a small world's step).
fn step_all(
    envs: &mut [Env],
    actions: &[Action],
    n: usize,
) -> Vec<Result<swarmrt_harness::env::Outcome, EnvError>> {
    use rayon::prelude::*;
    envs.par_iter_mut()
        .zip(actions.par_chunks(n.max(1)))
        .map(|(e, a)| e.step(a))
        .collect()
}

fn f64s(bytes: &[u8], count: usize, name: &str) -> PyResult<Vec<f64>> {
    if bytes.len() != count * 8 {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "{name} must hold {count} float64 values, not {} bytes",
            bytes.len()
        )));
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|c| f64::from_ne_bytes(c.try_into().expect("8 bytes")))
        .collect())
}

fn f64_bytes<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyBytes> {
    PyBytes::new(py, bytemuck::cast_slice(v))
}

fn features_dict<'py>(py: Python<'py>, f: &Features) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("pose", PyBytes::new(py, bytemuck::cast_slice(&f.pose)))?;
    d.set_item("goal", PyBytes::new(py, bytemuck::cast_slice(&f.goal)))?;
    d.set_item("lidar", PyBytes::new(py, bytemuck::cast_slice(&f.lidar)))?;
    d.set_item(
        "neighbours",
        PyBytes::new(py, bytemuck::cast_slice(&f.neighbours)),
    )?;
    d.set_item("neighbours_mask", PyBytes::new(py, &f.neighbours_mask))?;
    d.set_item("inbox", PyBytes::new(py, &f.inbox))?;
    d.set_item(
        "inbox_meta",
        PyBytes::new(py, bytemuck::cast_slice(&f.inbox_meta)),
    )?;
    d.set_item("inbox_mask", PyBytes::new(py, &f.inbox_mask))?;
    Ok(d)
}

/// One robot process's view of its observation (the bytes of a `swarmrt.Observation`), as
/// the environment computes it: the dict of [`VecEnv::observe`] for one robot.
#[pyfunction]
#[pyo3(signature = (observation, rays, neighbours, inbox, payload, lidar_range))]
pub fn features<'py>(
    py: Python<'py>,
    observation: &[u8],
    rays: usize,
    neighbours: usize,
    inbox: usize,
    payload: usize,
    lidar_range: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let o = observation_from(observation)?;
    let layout = Layout {
        rays,
        neighbours,
        inbox,
        payload,
    };
    let mut f = Features::zeroed(&layout, 1);
    f.fill(&layout, 0, &o, lidar_range);
    features_dict(py, &f)
}

/// The command bytes (a `swarmrt.Command`) robot `robot` sends at `tick` for an action, as
/// the environment applies it.
#[pyfunction]
pub fn command<'py>(
    py: Python<'py>,
    robot: u32,
    tick: u64,
    v: f64,
    omega: f64,
    say: Vec<u8>,
) -> Bound<'py, PyBytes> {
    let c: Command = Action { v, omega, say }.command(robot, tick);
    // SAFETY: Command is a repr(C) struct of plain numbers and arrays of them; its bytes,
    // padding included, are what the shared-memory sample would hold.
    let bytes = unsafe {
        std::slice::from_raw_parts(
            (&c as *const Command).cast::<u8>(),
            std::mem::size_of::<Command>(),
        )
    };
    PyBytes::new(py, bytes)
}

fn observation_from(bytes: &[u8]) -> PyResult<Observation> {
    if bytes.len() != std::mem::size_of::<Observation>() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "an observation is {} bytes, not {}",
            std::mem::size_of::<Observation>(),
            bytes.len()
        )));
    }
    let mut o = Observation::empty(0, 0);
    // SAFETY: Observation is a repr(C) struct of integers, floats and arrays of them, every
    // bit pattern of which is a valid value; the length was checked above.
    unsafe {
        std::ptr::copy_nonoverlapping(
            bytes.as_ptr(),
            (&mut o as *mut Observation).cast::<u8>(),
            bytes.len(),
        );
    }
    if RobotState::from_u8(o.state).is_none() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "observation state {} is no robot state",
            o.state
        )));
    }
    Ok(o)
}
