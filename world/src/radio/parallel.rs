//! [`RadioMedium::send`] over several threads, when nothing it decides draws from the radio
//! stream, asks for line of sight or is recorded: a crowd's broadcasts are most of a
//! 10,000-robot step.
//!
//! The copies are the same, in the same order per receiver, with the same counters, as the
//! one-thread path routes them: the receivers of each sender are found on threads split by
//! sender (each list in ascending id, as before), the frames are counted and stored in
//! routing order on one thread, and then each thread routes, in that order, the copies to
//! its own range of receivers, whose queues no other thread touches. Only what nobody reads
//! differs: routing sequence numbers (a FIFO's order is its arrival order) and which slot of
//! the frame store holds a frame.

use super::*;

/// Robots from which a send may split over threads. The two fork-joins run on rayon's pool,
/// whose threads stay parked between sends: at 1,000 robots the radio stage fell from
/// ~680 to ~590 us a tick (2 cores, `swarm-bench swarm --in-process-agents 1000`), where
/// spawning threads per send made it slower (~750 us). At 500 robots the send is a few
/// hundred microseconds and a fork-join's wake-ups eat what splitting it saves.
pub const PARALLEL_SEND_MIN: usize = 512;
/// Most threads a send uses.
const SEND_THREADS: usize = 4;

/// One frame that has copies to route: its sender, its slot in the frame store and whom it goes to.
struct Job {
    src: usize,
    slot: u32,
    /// `None`: the sender's broadcast receivers; else the one receiver of a unicast.
    dst: Option<u32>,
}

/// What one thread's routing adds to the medium.
#[derive(Default)]
struct Routed {
    in_flight: u64,
    partition: u64,
    /// Per job, the queue entries that refer to its frame.
    refs: Vec<u32>,
}

impl RadioMedium {
    /// Threads for a send of `n` robots, or `None` when it must take the one-thread path.
    pub(super) fn send_threads(&self) -> Option<usize> {
        let quiet = self.log.is_none()
            && !self.cfg.line_of_sight
            && self.cfg.jitter_ticks == 0
            && self.cfg.loss_model == LossModel::Bernoulli
            && self.cfg.loss <= 0.0;
        if !quiet || self.robot_count < PARALLEL_SEND_MIN {
            return None;
        }
        let threads = std::thread::available_parallelism()
            .map(|p| p.get())
            .unwrap_or(1)
            .min(SEND_THREADS);
        (threads > 1).then_some(threads)
    }

    /// [`RadioMedium::send`] on `threads` threads, the grid already rebuilt; see the module.
    pub(super) fn send_parallel(
        &mut self,
        tick: u64,
        outboxes: &[&[Frame]],
        positions: &[(f64, f64)],
        can_talk: &[bool],
        threads: usize,
    ) {
        let n = self.robot_count;
        let capacity = self.cfg.capacity as usize;
        let range = self.cfg.range;
        let chunk = n.div_ceil(threads);
        let broadcasts = |src: usize| {
            can_talk[src]
                && outboxes[src]
                    .iter()
                    .take(capacity)
                    .any(|f| f.dst == BROADCAST)
        };
        // 1. Receivers per broadcasting sender: (all lists of a range of senders, end of each).
        let grid = &self.grid;
        let find = |lo: usize| {
            let hi = (lo + chunk).min(n);
            let (mut all, mut ends) = (Vec::new(), Vec::with_capacity(hi - lo));
            let (mut out, mut marks) = (Vec::new(), Vec::new());
            for src in lo..hi {
                if broadcasts(src) {
                    receivers_of(grid, src, positions, range, &mut out, &mut marks);
                    all.extend_from_slice(&out);
                }
                ends.push(all.len());
            }
            (all, ends)
        };
        let lists: Vec<(Vec<u32>, Vec<usize>)> = on_threads(threads, |t| find(t * chunk));
        let receivers = |src: usize| -> &[u32] {
            let (all, ends) = &lists[src / chunk];
            let k = src % chunk;
            &all[if k == 0 { 0 } else { ends[k - 1] }..ends[k]]
        };

        // 2. Count every frame as the one-thread path does and store those with copies to route.
        let mut jobs = Vec::new();
        let mut copies = 0u64;
        for src in 0..n {
            if !can_talk[src] {
                continue;
            }
            for (k, frame) in outboxes[src].iter().enumerate() {
                self.stats.frames += 1;
                if k >= capacity {
                    self.stats.sent += 1;
                    self.stats.count_drop(Reason::Capacity);
                    continue;
                }
                let dst = if frame.dst == BROADCAST {
                    let to = receivers(src).len() as u64;
                    self.stats.sent += to;
                    if to == 0 {
                        continue;
                    }
                    copies += to;
                    None
                } else {
                    self.stats.sent += 1;
                    let dst = frame.dst as usize;
                    if dst < n && !can_talk[dst] {
                        self.stats.count_drop(Reason::ReceiverDown);
                        continue;
                    }
                    if dst >= n || dst == src || !in_range(positions[src], positions[dst], range) {
                        self.stats.count_drop(Reason::OutOfRange);
                        continue;
                    }
                    copies += 1;
                    Some(frame.dst)
                };
                let copy = Frame {
                    src: src as u32,
                    sent_tick: tick,
                    ..*frame
                };
                let slot = match self.free.pop() {
                    Some(free) => {
                        self.frames[free as usize] = (copy, 0);
                        free
                    }
                    None => {
                        self.frames.push((copy, 0));
                        (self.frames.len() - 1) as u32
                    }
                };
                jobs.push(Job { src, slot, dst });
            }
        }

        // 3. Each thread routes the copies to its own receivers, in routing order.
        let due = tick
            .saturating_add(1)
            .saturating_add(self.cfg.delay_ticks as u64);
        let groups = self.groups.as_deref();
        let seq = self.seq;
        let jobs = &jobs;
        let route = |t: usize, queues: &mut [Queue]| {
            let lo = t * chunk;
            let hi = lo + queues.len();
            // Sequence numbers only order one receiver's FIFO: each thread counts in its own
            // block, every block above those of earlier sends.
            let mut seq = seq + t as u64 * copies;
            let mut done = Routed {
                refs: vec![0; jobs.len()],
                ..Routed::default()
            };
            for (k, job) in jobs.iter().enumerate() {
                let one;
                let dsts: &[u32] = match job.dst {
                    None => {
                        let all = receivers(job.src);
                        let a = all.partition_point(|&d| (d as usize) < lo);
                        let b = all.partition_point(|&d| (d as usize) < hi);
                        &all[a..b]
                    }
                    Some(d) if (lo..hi).contains(&(d as usize)) => {
                        one = [d];
                        &one
                    }
                    Some(_) => &[],
                };
                for &dst in dsts {
                    let dst = dst as usize;
                    if groups.is_some_and(|g| g.get(job.src) != g.get(dst)) {
                        done.partition += 1;
                        continue;
                    }
                    done.in_flight += 1;
                    let queue = &mut queues[dst - lo];
                    if queue.absorb(due) {
                        continue;
                    }
                    done.refs[k] += 1;
                    queue.push(Pending {
                        due,
                        seq,
                        slot: job.slot,
                        surplus: 0,
                    });
                    seq += 1;
                }
            }
            done
        };
        let parts: Vec<std::sync::Mutex<&mut [Queue]>> = self
            .queues
            .chunks_mut(chunk)
            .map(std::sync::Mutex::new)
            .collect();
        let routed: Vec<Routed> = on_threads(parts.len(), |t| {
            let mut queues = parts[t].lock().unwrap_or_else(|e| e.into_inner());
            route(t, &mut queues)
        });
        drop(parts);
        self.seq = seq + threads as u64 * copies;
        for done in &routed {
            self.stats.in_flight += done.in_flight;
            self.stats.count_drops(Reason::Partition, done.partition);
        }
        for (k, job) in jobs.iter().enumerate() {
            let refs: u32 = routed.iter().map(|d| d.refs[k]).sum();
            self.frames[job.slot as usize].1 = refs;
            if refs == 0 {
                self.free.push(job.slot);
            }
        }
    }
}

/// `f(0)`, ..., `f(count - 1)` on `count` threads (this one runs `f(0)`, rayon's parked pool
/// the others), results in order.
fn on_threads<R: Send>(count: usize, f: impl Fn(usize) -> R + Sync) -> Vec<R> {
    let mut out: Vec<Option<R>> = (0..count).map(|_| None).collect();
    let (first, rest) = out.split_first_mut().expect("at least one thread");
    let f = &f;
    rayon::in_place_scope(|s| {
        for (t, slot) in rest.iter_mut().enumerate() {
            s.spawn(move |_| *slot = Some(f(t + 1)));
        }
        *first = Some(f(0));
    });
    out.into_iter()
        .map(|r| r.expect("every thread ran"))
        .collect()
}
