//! Noise-resistant particle swarm optimisation (NR-PSO) as a state machine: no I/O, no clock.
//!
//! The caller asks for a batch of positions ([`Pso::ask`]), evaluates them however it likes
//! (here: real runs), and tells the fitnesses back in the same order ([`Pso::tell`]), which
//! moves the swarm one iteration on. Fitness is minimised; a failed evaluation is
//! `f64::INFINITY` (any non-finite value counts as that).
//!
//! After Pugh, Martinoli and Zhang (2005) and Di Mario et al. (2015), as the flocking paper
//! used it (section II-D):
//! - ring (index) neighbourhood: particle `i` learns from the best personal best among
//!   `i - 1`, `i` and `i + 1`, wrapping;
//! - every iteration each particle's new position is evaluated once and its personal best is
//!   re-evaluated `R = E / P - 1` times; a personal best's fitness is the mean of all its
//!   evaluations so far, so a lucky draw is averaged away;
//! - a new position replaces the personal best when its single evaluation beats that mean;
//! - `v = w v + c1 r1 (pbest - x) + c2 r2 (lbest - x)`, each component clamped to
//!   `vmax * (hi - lo)`; a position that would leave its bounds stops at the bound and that
//!   velocity component is zeroed, so no parameter drifts past its bound through inertia.
//!
//! In iteration 0 the personal best is the start position itself, so its re-evaluations
//! sample the start position again: every iteration is exactly `E` evaluations.

use rand::Rng as _;
use swarmrt_scenario::rng::{Rng, stream};

/// Constants of the swarm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Particles `P` (at least 1).
    pub particles: usize,
    /// Evaluations per iteration `E`: `P` new positions plus `E - P` personal-best
    /// re-evaluations; `E - P` a non-negative multiple of `P`.
    pub evaluations: usize,
    /// Inertia `w`.
    pub inertia: f64,
    /// Cognitive (personal best) weight `c1`.
    pub c1: f64,
    /// Social (neighbourhood best) weight `c2`.
    pub c2: f64,
    /// Largest velocity component as a fraction of its bound width.
    pub vmax: f64,
}

impl Default for Options {
    /// Clerc's constriction constants (`w` = 0.729, `c1` = `c2` = 1.494), velocity at most
    /// one bound width, 7 particles and 14 evaluations (the paper's budget).
    fn default() -> Self {
        Options {
            particles: 7,
            evaluations: 14,
            inertia: 0.729,
            c1: 1.494,
            c2: 1.494,
            vmax: 1.0,
        }
    }
}

impl Options {
    /// Re-evaluations of each personal best per iteration, or an error naming the flag.
    pub fn reevaluations(&self) -> Result<usize, String> {
        let (p, e) = (self.particles, self.evaluations);
        if p == 0 {
            return Err("--particles: expected at least 1".into());
        }
        if e < p || (e - p) % p != 0 {
            return Err(format!(
                "--evaluations: expected a multiple of --particles ({p}) that is at least {p} \
                 (P new positions plus E - P re-evaluations spread evenly), e.g. {p}, {}, {}; got {e}",
                2 * p,
                3 * p
            ));
        }
        for (name, v) in [
            ("--inertia", self.inertia),
            ("--c1", self.c1),
            ("--c2", self.c2),
        ] {
            if !v.is_finite() || v < 0.0 {
                return Err(format!("{name}: expected a finite number >= 0, got {v}"));
            }
        }
        if !(self.vmax.is_finite() && self.vmax > 0.0) {
            return Err(format!(
                "--vmax: expected a finite number > 0, got {}",
                self.vmax
            ));
        }
        Ok(e / p - 1)
    }
}

/// Why a position is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// The particle's current position.
    New,
    /// Its personal best, again.
    Reeval,
}

impl Kind {
    /// `new` or `reeval`, as in `tune.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::New => "new",
            Kind::Reeval => "reeval",
        }
    }
}

/// One evaluation asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct Eval {
    /// Which particle.
    pub particle: usize,
    /// New position or re-evaluation.
    pub kind: Kind,
    /// The position, inside the bounds.
    pub position: Vec<f64>,
}

/// A personal best: where, and every evaluation of it so far.
#[derive(Debug, Clone, PartialEq)]
pub struct Best {
    /// The position.
    pub position: Vec<f64>,
    /// Sum of its evaluations.
    pub sum: f64,
    /// How many.
    pub count: usize,
}

impl Best {
    /// Mean fitness of its evaluations (infinite if one failed).
    pub fn mean(&self) -> f64 {
        self.sum / self.count as f64
    }
}

/// The swarm.
#[derive(Debug, Clone)]
pub struct Pso {
    bounds: Vec<(f64, f64)>,
    opts: Options,
    reevals: usize,
    rng: Rng,
    iteration: usize,
    x: Vec<Vec<f64>>,
    v: Vec<Vec<f64>>,
    pbest: Vec<Option<Best>>,
}

/// Particle `i`'s two ring neighbours among `p` (itself when `p` is 1 or 2 makes them repeat).
pub fn ring(i: usize, p: usize) -> [usize; 2] {
    [(i + p - 1) % p, (i + 1) % p]
}

impl Pso {
    /// A swarm over `bounds` (`lo < hi`, finite), positions drawn uniformly inside them and
    /// velocities `(u - x) / 2` for another uniform point `u`, all from `seed`.
    pub fn new(bounds: Vec<(f64, f64)>, opts: Options, seed: u64) -> Result<Pso, String> {
        let reevals = opts.reevaluations()?;
        if bounds.is_empty() {
            return Err("nothing to tune: give at least one --param".into());
        }
        for (d, &(lo, hi)) in bounds.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(format!("bound {d}: expected finite lo < hi, got {lo}:{hi}"));
            }
        }
        let mut rng = stream(seed, "tune-pso", 0);
        let mut x = Vec::with_capacity(opts.particles);
        let mut v = Vec::with_capacity(opts.particles);
        for _ in 0..opts.particles {
            let (mut xi, mut vi) = (Vec::new(), Vec::new());
            for &(lo, hi) in &bounds {
                let a = lo + rng.random::<f64>() * (hi - lo);
                let u = lo + rng.random::<f64>() * (hi - lo);
                xi.push(a);
                vi.push((u - a) / 2.0);
            }
            x.push(xi);
            v.push(vi);
        }
        Ok(Pso {
            pbest: vec![None; opts.particles],
            bounds,
            opts,
            reevals,
            rng,
            iteration: 0,
            x,
            v,
        })
    }

    /// Iterations told so far.
    pub fn iteration(&self) -> usize {
        self.iteration
    }

    /// The options.
    pub fn options(&self) -> &Options {
        &self.opts
    }

    /// The batch of this iteration, particle by particle: its new position, then its
    /// re-evaluations. Always `E` long.
    pub fn ask(&self) -> Vec<Eval> {
        let mut out = Vec::with_capacity(self.opts.evaluations);
        for (i, xi) in self.x.iter().enumerate() {
            out.push(Eval {
                particle: i,
                kind: Kind::New,
                position: xi.clone(),
            });
            let at = self.pbest[i].as_ref().map_or(xi, |b| &b.position);
            for _ in 0..self.reevals {
                out.push(Eval {
                    particle: i,
                    kind: Kind::Reeval,
                    position: at.clone(),
                });
            }
        }
        out
    }

    /// The fitnesses of [`Pso::ask`]'s batch, in its order: updates the personal bests, then
    /// moves every particle (synchronously, from the same personal bests).
    pub fn tell(&mut self, fitness: &[f64]) {
        assert_eq!(
            fitness.len(),
            self.opts.evaluations,
            "one fitness per evaluation"
        );
        let clean = |f: f64| if f.is_finite() { f } else { f64::INFINITY };
        let per = 1 + self.reevals;
        for i in 0..self.opts.particles {
            let fs = &fitness[i * per..(i + 1) * per];
            let new = clean(fs[0]);
            let again: f64 = fs[1..].iter().map(|&f| clean(f)).sum();
            match &mut self.pbest[i] {
                None => {
                    self.pbest[i] = Some(Best {
                        position: self.x[i].clone(),
                        sum: new + again,
                        count: per,
                    });
                }
                Some(b) => {
                    b.sum += again;
                    b.count += self.reevals;
                    if new < b.mean() {
                        *b = Best {
                            position: self.x[i].clone(),
                            sum: new,
                            count: 1,
                        };
                    }
                }
            }
        }
        let lbest: Vec<Vec<f64>> = (0..self.opts.particles)
            .map(|i| {
                self.pbest[self.local_best(i)]
                    .as_ref()
                    .expect("told")
                    .position
                    .clone()
            })
            .collect();
        let Options {
            inertia,
            c1,
            c2,
            vmax,
            ..
        } = self.opts;
        for (i, social) in lbest.iter().enumerate() {
            let own = self.pbest[i].as_ref().expect("told").position.clone();
            for (d, &(lo, hi)) in self.bounds.iter().enumerate() {
                let r1: f64 = self.rng.random();
                let r2: f64 = self.rng.random();
                let x = self.x[i][d];
                let limit = vmax * (hi - lo);
                let mut v =
                    inertia * self.v[i][d] + c1 * r1 * (own[d] - x) + c2 * r2 * (social[d] - x);
                v = v.clamp(-limit, limit);
                let mut nx = x + v;
                if nx <= lo {
                    nx = lo;
                    v = 0.0;
                } else if nx >= hi {
                    nx = hi;
                    v = 0.0;
                }
                self.x[i][d] = nx;
                self.v[i][d] = v;
            }
        }
        self.iteration += 1;
    }

    /// The particle among `i` and its ring neighbours with the lowest personal-best mean
    /// (`i` itself on a tie). Only after the first [`Pso::tell`].
    pub fn local_best(&self, i: usize) -> usize {
        let mean = |j: usize| self.pbest[j].as_ref().map_or(f64::INFINITY, Best::mean);
        let mut best = i;
        for j in ring(i, self.opts.particles) {
            if mean(j) < mean(best) {
                best = j;
            }
        }
        best
    }

    /// Particle `i`'s personal best (none before the first [`Pso::tell`]).
    pub fn personal_best(&self, i: usize) -> Option<&Best> {
        self.pbest[i].as_ref()
    }

    /// Particle `i`'s current position (what the next batch evaluates).
    pub fn position(&self, i: usize) -> &[f64] {
        &self.x[i]
    }

    /// The personal best with the lowest mean and its particle (the lowest index on a tie);
    /// none before the first [`Pso::tell`].
    pub fn best(&self) -> Option<(usize, &Best)> {
        let mut out: Option<(usize, &Best)> = None;
        for (i, b) in self.pbest.iter().enumerate() {
            if let Some(b) = b
                && out.is_none_or(|(_, o)| b.mean() < o.mean())
            {
                out = Some((i, b));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts(particles: usize, evaluations: usize) -> Options {
        Options {
            particles,
            evaluations,
            ..Options::default()
        }
    }

    #[test]
    fn evaluations_must_be_p_plus_a_multiple_of_p() {
        assert_eq!(opts(7, 14).reevaluations(), Ok(1));
        assert_eq!(opts(7, 7).reevaluations(), Ok(0));
        assert_eq!(opts(3, 9).reevaluations(), Ok(2));
        for bad in [6, 10, 0] {
            let e = opts(7, bad).reevaluations().unwrap_err();
            assert!(e.starts_with("--evaluations"), "{e}");
        }
        assert!(Pso::new(vec![(1.0, 1.0)], opts(2, 4), 1).is_err());
        assert!(Pso::new(vec![(0.0, f64::NAN)], opts(2, 4), 1).is_err());
    }

    /// (x - 1.5)^2 + (y + 2)^2 plus uniform noise in [-0.5, 0.5], minimised in [-5, 5]^2.
    #[test]
    fn minimises_a_noisy_sphere_within_bounds() {
        let bounds = vec![(-5.0, 5.0), (-5.0, 5.0)];
        let mut pso = Pso::new(bounds, opts(10, 30), 7).unwrap();
        let mut noise = stream(99, "test-noise", 0);
        for _ in 0..60 {
            let batch = pso.ask();
            let f: Vec<f64> = batch
                .iter()
                .map(|e| {
                    let p = &e.position;
                    (p[0] - 1.5).powi(2) + (p[1] + 2.0).powi(2) + noise.random::<f64>() - 0.5
                })
                .collect();
            pso.tell(&f);
        }
        let (_, best) = pso.best().unwrap();
        let p = &best.position;
        let dist = ((p[0] - 1.5).powi(2) + (p[1] + 2.0).powi(2)).sqrt();
        assert!(dist < 0.5, "best {p:?} is {dist} from the optimum");
    }

    #[test]
    fn never_leaves_its_bounds_even_pushed_against_them() {
        let bounds = vec![(0.0, 1.0), (-3.0, -2.0), (10.0, 1000.0)];
        let mut pso = Pso::new(bounds.clone(), opts(5, 10), 3).unwrap();
        let inside = |p: &[f64]| {
            p.iter()
                .zip(&bounds)
                .all(|(&x, &(lo, hi))| lo <= x && x <= hi)
        };
        for _ in 0..40 {
            let batch = pso.ask();
            assert!(batch.iter().all(|e| inside(&e.position)), "{batch:?}");
            // The optimum lies beyond the upper bounds: inertia would carry them past.
            let f: Vec<f64> = batch
                .iter()
                .map(|e| -e.position.iter().sum::<f64>())
                .collect();
            pso.tell(&f);
        }
        let (_, best) = pso.best().unwrap();
        assert!(inside(&best.position));
        assert_eq!(
            best.position[0], 1.0,
            "it reaches the bound and stays there"
        );
        assert_eq!(best.position[1], -2.0);
    }

    #[test]
    fn ring_neighbourhood_wraps_and_sees_only_neighbours() {
        assert_eq!(ring(0, 5), [4, 1]);
        assert_eq!(ring(4, 5), [3, 0]);
        assert_eq!(ring(2, 5), [1, 3]);
        assert_eq!(ring(0, 1), [0, 0]);
        // Particle 0 is by far the best; particle 2 is not its neighbour among 5.
        let mut pso = Pso::new(vec![(0.0, 1.0)], opts(5, 5), 1).unwrap();
        pso.tell(&[0.0, 5.0, 3.0, 4.0, 6.0]);
        assert_eq!(pso.local_best(1), 0);
        assert_eq!(pso.local_best(4), 0);
        assert_eq!(pso.local_best(2), 2, "its neighbours 1 and 3 are worse");
        assert_eq!(pso.local_best(3), 2);
        assert_eq!(pso.best().unwrap().0, 0);
    }

    #[test]
    fn personal_bests_average_every_evaluation() {
        let mut pso = Pso::new(vec![(0.0, 1.0)], opts(1, 3), 5).unwrap();
        let start = pso.position(0).to_vec();
        let batch = pso.ask();
        assert_eq!(
            batch.iter().map(|e| e.kind).collect::<Vec<_>>(),
            [Kind::New, Kind::Reeval, Kind::Reeval]
        );
        assert!(batch.iter().all(|e| e.position == start));
        pso.tell(&[5.0, 1.0, 3.0]);
        let b = pso.personal_best(0).unwrap();
        assert_eq!((b.count, b.mean()), (3, 3.0));

        // A worse new position: the old best stays and gathers two more evaluations.
        assert!(pso.ask()[1..].iter().all(|e| e.position == start));
        pso.tell(&[10.0, 7.0, 7.0]);
        let b = pso.personal_best(0).unwrap();
        assert_eq!((b.count, b.sum), (5, 23.0));
        assert_eq!(b.position, start);

        // Its mean rises past a new single evaluation: replaced, with that one evaluation.
        let moved = pso.position(0).to_vec();
        pso.tell(&[2.0, 100.0, 100.0]);
        let b = pso.personal_best(0).unwrap();
        assert_eq!((b.count, b.mean()), (1, 2.0));
        assert_eq!(b.position, moved);

        // A failed evaluation is the worst fitness, never a panic or a NaN best.
        pso.tell(&[f64::NAN, f64::INFINITY, 1.0]);
        assert_eq!(pso.personal_best(0).unwrap().mean(), f64::INFINITY);
        pso.tell(&[4.0, 1.0, 1.0]);
        assert_eq!(pso.personal_best(0).unwrap().mean(), 4.0);
    }

    #[test]
    fn same_seed_same_swarm() {
        let run = |seed| {
            let mut pso = Pso::new(vec![(0.0, 2.0), (-1.0, 1.0)], opts(4, 8), seed).unwrap();
            let mut asked = Vec::new();
            for _ in 0..5 {
                let b = pso.ask();
                let f: Vec<f64> = b.iter().map(|e| e.position[0] * e.position[1]).collect();
                asked.push(b);
                pso.tell(&f);
            }
            asked
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
    }
}
