//! The medium's tests: accounting, loss models, delay and jitter, capacity, range, line of
//! sight, receivers down, inbox overflow, the receivers' grid against brute force, and
//! determinism over random scenarios.

use super::*;
use swarmrt_protocol::MAX_OUTBOX;

fn base_cfg() -> RadioConfig {
    RadioConfig {
        range: 10.0,
        loss: 0.0,
        loss_model: LossModel::Bernoulli,
        delay_ticks: 0,
        jitter_ticks: 0,
        capacity: 4,
        line_of_sight: false,
        ..RadioConfig::default()
    }
}

fn frame(dst: u32, tag: u32) -> Frame {
    let mut f = Frame::EMPTY;
    f.dst = dst;
    f.len = 4;
    f.payload[..4].copy_from_slice(&tag.to_le_bytes());
    f
}

fn tag(f: &Frame) -> u32 {
    u32::from_le_bytes(f.payload[..4].try_into().unwrap())
}

fn check(s: &RadioStats) {
    assert_eq!(s.sent, s.delivered + s.dropped + s.in_flight, "{s:?}");
    assert_eq!(
        s.dropped,
        s.dropped_loss
            + s.dropped_out_of_range
            + s.dropped_capacity
            + s.dropped_line_of_sight
            + s.dropped_receiver_down
            + s.dropped_inbox_full
            + s.dropped_partition,
        "{s:?}"
    );
}

fn send(m: &mut RadioMedium, tick: u64, out: &[Vec<Frame>], pos: &[(f64, f64)], talk: &[bool]) {
    let refs: Vec<&[Frame]> = out.iter().map(|v| v.as_slice()).collect();
    m.send(tick, &refs, pos, talk, &mut |_, _| false);
    check(&m.stats());
}

fn deliver(m: &mut RadioMedium, tick: u64, talk: &[bool]) -> Vec<Vec<Frame>> {
    let mut inboxes = vec![Vec::new(); talk.len()];
    m.deliver(tick, talk, &mut inboxes);
    check(&m.stats());
    inboxes
}

#[test]
fn bernoulli_loss_rate_is_within_bounds() {
    let cfg = RadioConfig {
        loss: 0.3,
        capacity: 8,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 42, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let out = vec![(0..8).map(|k| frame(BROADCAST, k)).collect(), Vec::new()];
    let mut received = 0u64;
    for t in 0..3000 {
        send(&mut m, t, &out, &pos, &talk);
        received += deliver(&mut m, t + 1, &talk)[1].len() as u64;
    }
    let s = m.stats();
    assert_eq!(s.sent, 24_000);
    assert_eq!(s.delivered, received);
    assert_eq!(s.in_flight, 0);
    assert_eq!(s.dropped, s.dropped_loss);
    let rate = s.dropped_loss as f64 / s.sent as f64;
    assert!((rate - 0.3).abs() < 0.02, "loss rate {rate}");
}

#[test]
fn gilbert_elliott_bursts_last_one_over_r_and_lose_p_over_p_plus_r() {
    let (p, r) = (0.1, 0.25);
    let cfg = RadioConfig {
        loss_model: LossModel::GilbertElliott,
        ge_p: p,
        ge_r: r,
        ge_loss_good: 0.0,
        ge_loss_bad: 1.0,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 7, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let out = vec![vec![frame(1, 0)], Vec::new()];
    let ticks = 60_000u64;
    let mut lost = Vec::with_capacity(ticks as usize);
    for t in 0..ticks {
        send(&mut m, t, &out, &pos, &talk);
        lost.push(deliver(&mut m, t + 1, &talk)[1].is_empty());
    }
    let mut bursts = Vec::new();
    let mut run = 0u64;
    for &l in &lost {
        if l {
            run += 1;
        } else if run > 0 {
            bursts.push(run);
            run = 0;
        }
    }
    let mean = bursts.iter().sum::<u64>() as f64 / bursts.len() as f64;
    assert!((mean - 1.0 / r).abs() < 0.4, "mean burst {mean}");
    let rate = m.stats().dropped_loss as f64 / ticks as f64;
    assert!((rate - p / (p + r)).abs() < 0.02, "loss rate {rate}");
}

#[test]
fn gilbert_elliott_links_are_independent_per_direction() {
    // Loss only in Bad, and Bad is absorbing: once a link turns Bad it loses forever.
    let cfg = RadioConfig {
        loss_model: LossModel::GilbertElliott,
        ge_p: 0.05,
        ge_r: 0.0,
        ge_loss_good: 0.0,
        ge_loss_bad: 1.0,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 3, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let out = vec![vec![frame(1, 0)], vec![frame(0, 0)]];
    let mut first_loss = [None, None];
    for t in 0..400 {
        send(&mut m, t, &out, &pos, &talk);
        let inboxes = deliver(&mut m, t + 1, &talk);
        for (link, inbox) in [(0usize, &inboxes[1]), (1, &inboxes[0])] {
            if inbox.is_empty() {
                first_loss[link].get_or_insert(t);
            } else {
                assert!(first_loss[link].is_none(), "a Bad link recovered");
            }
        }
    }
    assert!(first_loss[0].is_some() && first_loss[1].is_some());
    assert_ne!(first_loss[0], first_loss[1], "links share state");
}

#[test]
fn fixed_delay_arrives_exactly_at_t_plus_one_plus_delay() {
    let cfg = RadioConfig {
        delay_ticks: 3,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 1, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    send(&mut m, 5, &[vec![frame(BROADCAST, 9)], vec![]], &pos, &talk);
    for t in 5..9 {
        assert!(deliver(&mut m, t, &talk)[1].is_empty(), "early at {t}");
        assert_eq!(m.stats().in_flight, 1);
    }
    let inbox = deliver(&mut m, 9, &talk);
    assert_eq!(inbox[1].len(), 1);
    assert_eq!(tag(&inbox[1][0]), 9);
    assert_eq!(inbox[1][0].sent_tick, 5);
    assert!(inbox[0].is_empty());
    assert!(deliver(&mut m, 10, &talk)[1].is_empty());
    assert_eq!(m.stats().delivered, 1);
    assert_eq!(m.stats().in_flight, 0);
}

#[test]
fn jitter_spreads_over_the_whole_range_and_reorders() {
    let jitter = 4u64;
    let cfg = RadioConfig {
        delay_ticks: 1,
        jitter_ticks: jitter as u32,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 11, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let mut seen = [0u32; 5];
    let mut arrival_order = Vec::new();
    for t in 0..400u64 {
        let out = if t < 300 {
            vec![vec![frame(1, t as u32)], vec![]]
        } else {
            vec![vec![], vec![]]
        };
        send(&mut m, t, &out, &pos, &talk);
        for f in &deliver(&mut m, t + 1, &talk)[1] {
            let extra = t + 1 - f.sent_tick - 2;
            assert!(extra <= jitter, "delay beyond jitter");
            seen[extra as usize] += 1;
            assert_eq!(tag(f) as u64, f.sent_tick);
            arrival_order.push(tag(f));
        }
    }
    assert!(seen.iter().all(|&c| c > 0), "jitter values seen {seen:?}");
    assert_eq!(arrival_order.len(), 300);
    assert!(
        arrival_order.windows(2).any(|w| w[1] < w[0]),
        "jitter never reordered"
    );
}

#[test]
fn capacity_drops_the_excess_frames() {
    let k = 4usize;
    let mut m = RadioMedium::new(base_cfg(), 1, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let out = vec![
        (0..k as u32 + 3).map(|i| frame(BROADCAST, i)).collect(),
        vec![],
    ];
    send(&mut m, 0, &out, &pos, &talk);
    let inbox = deliver(&mut m, 1, &talk);
    let s = m.stats();
    assert_eq!(s.frames, k as u64 + 3);
    assert_eq!(s.sent, k as u64 + 3);
    assert_eq!(s.dropped_capacity, 3);
    assert_eq!(s.delivered, k as u64);
    let tags: Vec<u32> = inbox[1].iter().map(tag).collect();
    assert_eq!(
        tags,
        vec![0, 1, 2, 3],
        "the first K frames pass, in outbox order"
    );
}

#[test]
fn out_of_range_robot_receives_nothing_and_is_not_counted() {
    let mut m = RadioMedium::new(base_cfg(), 1, 3);
    let pos = [(0.0, 0.0), (10.0, 0.0), (10.01, 0.0)];
    let talk = [true, true, true];
    send(
        &mut m,
        0,
        &[vec![frame(BROADCAST, 1)], vec![], vec![]],
        &pos,
        &talk,
    );
    assert_eq!(
        m.stats().sent,
        1,
        "exactly at range counts, beyond does not"
    );
    send(
        &mut m,
        1,
        &[vec![frame(2, 2), frame(0, 3)], vec![], vec![]],
        &pos,
        &talk,
    );
    let inbox = deliver(&mut m, 2, &talk);
    assert_eq!(inbox[1].len(), 1);
    assert!(inbox[2].is_empty());
    assert!(inbox[0].is_empty());
    let s = m.stats();
    assert_eq!(s.frames, 3);
    assert_eq!(s.sent, 3);
    assert_eq!(
        s.dropped_out_of_range, 2,
        "unicast out of range and to itself"
    );
    assert_eq!(s.delivered, 1);

    // A broadcast nobody hears counts only in `frames`.
    send(&mut m, 3, &[vec![], vec![], vec![]], &pos, &talk);
    let far = [(0.0, 0.0), (50.0, 0.0), (100.0, 0.0)];
    send(
        &mut m,
        4,
        &[vec![frame(BROADCAST, 4)], vec![], vec![]],
        &far,
        &talk,
    );
    assert_eq!(m.stats().frames, 4);
    assert_eq!(m.stats().sent, 3);
}

#[test]
fn blocked_pair_is_dropped_for_line_of_sight() {
    let cfg = RadioConfig {
        line_of_sight: true,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 1, 4);
    let pos = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (50.0, 0.0)];
    let talk = [true, true, true, true];
    let out: Vec<&[Frame]> = vec![&[], &[], &[], &[]];
    let bc = [frame(BROADCAST, 0)];
    let out0: Vec<&[Frame]> = vec![&bc, out[1], out[2], out[3]];
    let mut asked = Vec::new();
    m.send(0, &out0, &pos, &talk, &mut |a, b| {
        asked.push((a, b));
        b == 2
    });
    assert_eq!(
        asked,
        vec![(0, 1), (0, 2)],
        "asked only for in-range pairs, in order"
    );
    let inbox = deliver(&mut m, 1, &talk);
    assert_eq!(inbox[1].len(), 1);
    assert!(inbox[2].is_empty());
    assert!(inbox[3].is_empty());
    let s = m.stats();
    assert_eq!(s.sent, 2);
    assert_eq!(s.dropped_line_of_sight, 1);
    assert_eq!(s.delivered, 1);

    // Without line of sight the callback is never asked.
    let mut m = RadioMedium::new(base_cfg(), 1, 4);
    m.send(0, &out0, &pos, &talk, &mut |_, _| {
        panic!("asked without line_of_sight")
    });
    assert_eq!(m.stats().in_flight, 2);
}

#[test]
fn receiver_down_at_send_or_before_delivery_is_counted() {
    let cfg = RadioConfig {
        delay_ticks: 2,
        ..base_cfg()
    };
    let mut m = RadioMedium::new(cfg, 1, 3);
    let pos = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)];
    let up = [true, true, true];
    send(&mut m, 0, &[vec![frame(1, 0)], vec![], vec![]], &pos, &up);
    assert_eq!(m.stats().in_flight, 1);
    let one_down = [true, false, true];
    assert!(deliver(&mut m, 1, &one_down)[1].is_empty());
    assert!(deliver(&mut m, 3, &one_down)[1].is_empty());
    let s = m.stats();
    assert_eq!(s.dropped_receiver_down, 1);
    assert_eq!(s.in_flight, 0);
    assert_eq!(s.delivered, 0);

    // At send time: a unicast to a down robot is counted; a broadcast skips it; a down
    // robot's outbox is ignored entirely.
    send(
        &mut m,
        4,
        &[
            vec![frame(1, 1), frame(BROADCAST, 2)],
            vec![frame(BROADCAST, 3)],
            vec![],
        ],
        &pos,
        &one_down,
    );
    let s = m.stats();
    assert_eq!(s.frames, 3);
    assert_eq!(s.sent, 3);
    assert_eq!(s.dropped_receiver_down, 2);
    let inbox = deliver(&mut m, 7, &up);
    assert_eq!(inbox[2].len(), 1);
    assert_eq!(inbox[2][0].src, 0);
    assert!(inbox[1].is_empty());
}

#[test]
fn inbox_overflow_delivers_max_inbox_and_drops_the_rest() {
    let n = 10;
    let mut m = RadioMedium::new(base_cfg(), 1, n);
    let pos: Vec<(f64, f64)> = (0..n).map(|i| (i as f64 * 0.5, 0.0)).collect();
    let talk = vec![true; n];
    let mut out = vec![Vec::new(); n];
    for (i, o) in out.iter_mut().enumerate().skip(1) {
        *o = (0..4).map(|k| frame(0, (i * 10 + k) as u32)).collect();
    }
    send(&mut m, 0, &out, &pos, &talk);
    assert_eq!(m.stats().in_flight, 36);
    let inbox = deliver(&mut m, 1, &talk);
    assert_eq!(inbox[0].len(), MAX_INBOX);
    let srcs: Vec<u32> = inbox[0].iter().map(|f| f.src).collect();
    let expected: Vec<u32> = (1..=8).flat_map(|i| [i; 4]).collect();
    assert_eq!(
        srcs, expected,
        "routing order: senders ascending, outbox order"
    );
    let s = m.stats();
    assert_eq!(s.delivered, MAX_INBOX as u64);
    assert_eq!(s.dropped_inbox_full, 36 - MAX_INBOX as u64);
    assert_eq!(s.in_flight, 0);
    assert!(
        deliver(&mut m, 2, &talk)[0].is_empty(),
        "overflow is not kept"
    );
}

/// Copies beyond a full inbox's worth wait as a count on the last queued copy; they must still
/// be counted as the per-copy path counts them: inbox full if the receiver talks at delivery,
/// receiver down if it stopped, and each due tick on its own.
#[test]
fn surplus_copies_are_counted_like_queued_ones() {
    let n = 41;
    let cfg = RadioConfig {
        delay_ticks: 1,
        capacity: 2,
        ..base_cfg()
    };
    let pos: Vec<(f64, f64)> = (0..n).map(|i| (i as f64 * 0.1, 0.0)).collect();
    let talk = vec![true; n];
    // Robots 1..=40 each send two frames to robot 0 at ticks 0 and 1: 80 copies per tick.
    let out: Vec<Vec<Frame>> = (0..n)
        .map(|i| match i {
            0 => vec![],
            _ => vec![frame(0, i as u32), frame(BROADCAST, 1000 + i as u32)],
        })
        .collect();
    let mut m = RadioMedium::new(cfg, 1, n);
    send(&mut m, 0, &out, &pos, &talk);
    send(&mut m, 1, &out, &pos, &talk);
    assert_eq!(m.stats().in_flight, m.stats().sent);
    // Tick 2: the copies sent at tick 0 are due; robot 0 keeps the first 32 in routing order.
    let inbox = deliver(&mut m, 2, &talk);
    let tags: Vec<u32> = inbox[0].iter().map(tag).collect();
    let expected: Vec<u32> = (1..=16).flat_map(|i| [i, 1000 + i]).collect();
    assert_eq!(tags, expected);
    // Everyone hears everyone: robot 0 gets 80 copies, each other robot 39 broadcasts.
    let s = m.stats();
    let k = MAX_INBOX as u64;
    assert_eq!(s.delivered, 41 * k);
    assert_eq!(s.dropped_inbox_full, (80 - k) + 40 * (39 - k));
    assert_eq!(s.dropped_receiver_down, 0);
    // Tick 3: robot 0 is down, so every one of its copies sent at tick 1 is receiver-down,
    // the counted surplus included; the others' copies are delivered as usual.
    let mut zero_down = talk.clone();
    zero_down[0] = false;
    let before = m.stats();
    let inbox = deliver(&mut m, 3, &zero_down);
    assert!(inbox[0].is_empty());
    let s = m.stats();
    assert_eq!(s.dropped_receiver_down - before.dropped_receiver_down, 80);
    assert_eq!(
        s.dropped_inbox_full - before.dropped_inbox_full,
        40 * (39 - k)
    );
    assert_eq!(s.delivered - before.delivered, 40 * k);
    assert_eq!(s.in_flight, 0);
}

#[test]
fn world_sets_src_and_sent_tick_and_keeps_dst() {
    let mut m = RadioMedium::new(base_cfg(), 1, 2);
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let mut forged = frame(1, 5);
    forged.src = 1;
    forged.sent_tick = 999;
    send(
        &mut m,
        17,
        &[vec![forged, frame(BROADCAST, 6)], vec![]],
        &pos,
        &talk,
    );
    let inbox = deliver(&mut m, 18, &talk);
    assert_eq!(inbox[1].len(), 2);
    assert_eq!(
        (inbox[1][0].src, inbox[1][0].sent_tick, inbox[1][0].dst),
        (0, 17, 1)
    );
    assert_eq!(inbox[1][1].dst, BROADCAST);
    assert_eq!(inbox[1][1].bytes(), &6u32.to_le_bytes());
}

#[test]
fn grid_finds_exactly_the_brute_force_receivers() {
    for seed in 0..30u64 {
        let mut r = rng::stream(seed, "radio-test-grid", 0);
        let n = r.random_range(2..=80usize);
        let range = [0.0, 1.0, 2.5, 5.0, 7.0][r.random_range(0..5usize)];
        // Integer lattice: many exact-range pairs (3-4-5) and some coincident robots.
        let pos: Vec<(f64, f64)> = (0..n)
            .map(|_| {
                (
                    r.random_range(-20..=20i32) as f64,
                    r.random_range(-20..=20i32) as f64,
                )
            })
            .collect();
        let talk: Vec<bool> = (0..n).map(|_| r.random::<f64>() < 0.85).collect();
        let cfg = RadioConfig {
            range,
            line_of_sight: true,
            ..base_cfg()
        };
        let mut m = RadioMedium::new(cfg, seed, n);
        let out: Vec<Vec<Frame>> = (0..n).map(|_| vec![frame(BROADCAST, 0)]).collect();
        let refs: Vec<&[Frame]> = out.iter().map(|v| v.as_slice()).collect();
        // The line-of-sight callback reveals the routing order: senders, then receivers,
        // both ascending.
        let mut routed = Vec::new();
        m.send(0, &refs, &pos, &talk, &mut |a, b| {
            routed.push((a, b));
            false
        });
        check(&m.stats());
        let inbox = deliver(&mut m, 1, &talk);
        let hears = |tx: usize, rx: usize| {
            talk[tx] && talk[rx] && tx != rx && {
                let (dx, dy) = (pos[tx].0 - pos[rx].0, pos[tx].1 - pos[rx].1);
                (dx * dx + dy * dy).sqrt() <= range
            }
        };
        let expected_routing: Vec<(usize, usize)> = (0..n)
            .flat_map(|tx| (0..n).map(move |rx| (tx, rx)))
            .filter(|&(tx, rx)| hears(tx, rx))
            .collect();
        assert_eq!(routed, expected_routing, "seed {seed} range {range}");
        let mut pairs = 0u64;
        for (rx, inbox) in inbox.iter().enumerate() {
            let expected: Vec<u32> = (0..n)
                .filter(|&tx| hears(tx, rx))
                .map(|tx| tx as u32)
                .collect();
            pairs += expected.len() as u64;
            if expected.len() <= MAX_INBOX {
                let got: Vec<u32> = inbox.iter().map(|f| f.src).collect();
                assert_eq!(got, expected, "seed {seed} robot {rx} range {range}");
            }
        }
        assert_eq!(m.stats().sent, pairs, "seed {seed}");
    }
}

#[test]
fn ten_thousand_robots_broadcast_in_one_tick() {
    let side = 100usize;
    let n = side * side;
    let spacing = 4.0;
    let mut m = RadioMedium::new(base_cfg(), 1, n);
    let pos: Vec<(f64, f64)> = (0..n)
        .map(|i| ((i % side) as f64 * spacing, (i / side) as f64 * spacing))
        .collect();
    let talk = vec![true; n];
    let out: Vec<Vec<Frame>> = (0..n).map(|i| vec![frame(BROADCAST, i as u32)]).collect();
    send(&mut m, 0, &out, &pos, &talk);
    // Lattice neighbours within 10 m at 4 m spacing: offsets with dx^2 + dy^2 <= 6.25.
    let mut expected = 0u64;
    for i in 0..n {
        let (x, y) = ((i % side) as i64, (i / side) as i64);
        for dx in -2i64..=2 {
            for dy in -2i64..=2 {
                let (nx, ny) = (x + dx, y + dy);
                let inside = (0..side as i64).contains(&nx) && (0..side as i64).contains(&ny);
                if (dx, dy) != (0, 0) && inside && ((dx * dx + dy * dy) as f64) * 16.0 <= 100.0 {
                    expected += 1;
                }
            }
        }
    }
    assert_eq!(m.stats().sent, expected);
    deliver(&mut m, 1, &talk);
    assert_eq!(m.stats().delivered, expected);
}

/// Everything a run of the medium produced: (tick, robot, inbox) for non-empty inboxes.
type Transcript = Vec<(u64, usize, Vec<Frame>)>;

/// A random scenario (robots moving, going down and up, random outboxes and config),
/// checking the accounting after every call and the shape of every delivered frame.
fn random_run(scenario: u64, radio_seed: u64) -> (Transcript, RadioStats) {
    let (transcript, stats, rows) = random_run_recorded(scenario, radio_seed, false);
    assert!(rows.is_empty(), "no rows without recording");
    (transcript, stats)
}

/// [`random_run`], recording when `record`: also the rows taken after every call.
fn random_run_recorded(
    scenario: u64,
    radio_seed: u64,
    record: bool,
) -> (Transcript, RadioStats, Vec<RadioRow>) {
    let mut r = rng::stream(scenario, "radio-test-scenario", 0);
    let n = r.random_range(2..=40usize);
    let broadcast_share: f64 = r.random_range(0.2..0.95);
    let cfg = RadioConfig {
        range: r.random_range(3.0..15.0),
        loss: r.random_range(0.0..0.6),
        loss_model: if r.random::<bool>() {
            LossModel::Bernoulli
        } else {
            LossModel::GilbertElliott
        },
        ge_p: r.random_range(0.0..0.5),
        ge_r: r.random_range(0.05..1.0),
        ge_loss_good: r.random_range(0.0..0.2),
        ge_loss_bad: r.random_range(0.5..=1.0),
        delay_ticks: r.random_range(0..=3),
        jitter_ticks: r.random_range(0..=3),
        capacity: r.random_range(1..=MAX_OUTBOX as u32),
        line_of_sight: r.random::<bool>(),
        rounds: 0,
    };
    let max_lag = 1 + cfg.delay_ticks as u64 + cfg.jitter_ticks as u64;
    let mut m = RadioMedium::new(cfg, radio_seed, n);
    m.set_recording(record);
    let mut rows = Vec::new();
    let side: f64 = r.random_range(4.0..30.0);
    let mut pos: Vec<(f64, f64)> = (0..n)
        .map(|_| (r.random_range(0.0..side), r.random_range(0.0..side)))
        .collect();
    let mut talk: Vec<bool> = (0..n).map(|_| r.random::<f64>() < 0.9).collect();
    let mut transcript = Vec::new();
    let mut expected_frames = 0u64;
    let ticks = 80u64;
    for t in 0..ticks + max_lag {
        let mut inboxes = vec![Vec::new(); n];
        m.deliver(t, &talk, &mut inboxes);
        check(&m.stats());
        rows.extend(m.take_log());
        for (rx, inbox) in inboxes.into_iter().enumerate() {
            assert!(inbox.len() <= MAX_INBOX);
            for f in &inbox {
                assert!(talk[rx]);
                assert_ne!(f.src as usize, rx);
                assert!(f.sent_tick < t && t - f.sent_tick <= max_lag);
                assert!(f.dst == BROADCAST || f.dst as usize == rx);
            }
            if !inbox.is_empty() {
                transcript.push((t, rx, inbox));
            }
        }
        if t >= ticks {
            // Drain: everyone talks, nobody sends.
            talk.iter_mut().for_each(|c| *c = true);
            m.set_groups(None);
            continue;
        }
        // A partition of odd and even ids for a while (no draw: the scenario stays the same).
        m.set_groups(
            (20..30)
                .contains(&t)
                .then(|| (0..n as u64).map(|i| i % 2).collect()),
        );
        let out: Vec<Vec<Frame>> = (0..n)
            .map(|i| {
                let len = r.random_range(0..=MAX_OUTBOX);
                if talk[i] {
                    expected_frames += len as u64;
                }
                (0..len)
                    .map(|k| {
                        let dst = if r.random::<f64>() < broadcast_share {
                            BROADCAST
                        } else {
                            r.random_range(0..n as u32)
                        };
                        frame(dst, (t * 1000 + i as u64 * 10 + k as u64) as u32)
                    })
                    .collect()
            })
            .collect();
        let refs: Vec<&[Frame]> = out.iter().map(|v| v.as_slice()).collect();
        m.send(t, &refs, &pos, &talk, &mut |a, b| (a * 7 + b * 3) % 5 == 0);
        check(&m.stats());
        rows.extend(m.take_log());
        assert_eq!(m.stats().frames, expected_frames);
        for p in pos.iter_mut() {
            p.0 += r.random_range(-1.0..1.0);
            p.1 += r.random_range(-1.0..1.0);
        }
        for c in talk.iter_mut() {
            if r.random::<f64>() < 0.05 {
                *c = !*c;
            }
        }
    }
    let s = m.stats();
    assert_eq!(s.in_flight, 0, "everything drains");
    (transcript, s, rows)
}

/// Rows per outcome, in [`RadioOutcome::ALL`] order.
fn outcome_counts(rows: &[RadioRow]) -> [u64; 8] {
    let mut counts = [0; 8];
    for r in rows {
        counts[RadioOutcome::ALL
            .iter()
            .position(|&o| o == r.outcome)
            .unwrap()] += 1;
    }
    counts
}

/// The counters in [`RadioOutcome::ALL`] order.
fn counter_counts(s: &RadioStats) -> [u64; 8] {
    [
        s.delivered,
        s.dropped_loss,
        s.dropped_out_of_range,
        s.dropped_capacity,
        s.dropped_line_of_sight,
        s.dropped_receiver_down,
        s.dropped_inbox_full,
        s.dropped_partition,
    ]
}

/// Recording changes no inbox, counter or draw, and leaves one row per decided copy: per
/// outcome as many as its counter, the delivered ones exactly the inboxes' frames.
#[test]
fn recording_changes_nothing_and_rows_match_the_counters() {
    let mut totals = [0u64; 8];
    for scenario in 0..40 {
        let (plain, plain_stats) = random_run(scenario, scenario + 7);
        let (recorded, stats, rows) = random_run_recorded(scenario, scenario + 7, true);
        assert!(
            plain == recorded,
            "scenario {scenario}: recording changed an inbox"
        );
        assert_eq!(plain_stats, stats, "scenario {scenario}");
        assert_eq!(rows.len() as u64, stats.sent - stats.in_flight);
        assert_eq!(outcome_counts(&rows), counter_counts(&stats), "{stats:?}");
        // Rows are in decision order: ticks never go back.
        assert!(rows.windows(2).all(|w| w[0].tick <= w[1].tick));
        for r in &rows {
            assert!(r.sent_tick <= r.tick && r.bytes == 4);
            assert!(r.to.is_some() || r.outcome == RadioOutcome::Capacity);
        }
        // The delivered rows are the inboxes, frame by frame, in delivery order.
        let delivered: Vec<(u64, u32, u32, u64)> = rows
            .iter()
            .filter(|r| r.outcome == RadioOutcome::Delivered)
            .map(|r| (r.tick, r.to.unwrap(), r.from, r.sent_tick))
            .collect();
        let inboxes: Vec<(u64, u32, u32, u64)> = recorded
            .iter()
            .flat_map(|(t, rx, inbox)| {
                inbox
                    .iter()
                    .map(move |f| (*t, *rx as u32, f.src, f.sent_tick))
            })
            .collect();
        assert_eq!(delivered, inboxes, "scenario {scenario}");
        for (t, c) in totals.iter_mut().zip(counter_counts(&stats)) {
            *t += c;
        }
    }
    assert!(
        totals.iter().all(|&c| c > 0),
        "every outcome happened: {totals:?}"
    );
}

/// Copies past a full inbox's worth wait as a count when not recording; recording, each gets
/// its own row, with the same counters at every step.
#[test]
fn surplus_copies_get_one_row_each_when_recording() {
    let n = 41;
    let cfg = RadioConfig {
        delay_ticks: 1,
        capacity: 2,
        ..base_cfg()
    };
    let pos: Vec<(f64, f64)> = (0..n).map(|i| (i as f64 * 0.1, 0.0)).collect();
    let talk = vec![true; n];
    let mut zero_down = talk.clone();
    zero_down[0] = false;
    let out: Vec<Vec<Frame>> = (0..n)
        .map(|i| match i {
            0 => vec![],
            _ => vec![
                frame(0, i as u32),
                frame(BROADCAST, 1000 + i as u32),
                frame(0, 7),
            ],
        })
        .collect();
    let (mut plain, mut recorded) = (RadioMedium::new(cfg, 1, n), RadioMedium::new(cfg, 1, n));
    recorded.set_recording(true);
    let mut rows = Vec::new();
    for t in 0..2 {
        for m in [&mut plain, &mut recorded] {
            send(m, t, &out, &pos, &talk);
        }
        assert_eq!(plain.stats(), recorded.stats());
        rows.extend(recorded.take_log());
    }
    for (t, talk) in [(2, &talk), (3, &zero_down)] {
        let a = deliver(&mut plain, t, talk);
        let b = deliver(&mut recorded, t, talk);
        assert_eq!(a, b);
        assert_eq!(plain.stats(), recorded.stats());
        rows.extend(recorded.take_log());
    }
    let s = recorded.stats();
    assert_eq!(s.in_flight, 0);
    assert!(s.dropped_inbox_full > 0 && s.dropped_receiver_down >= 80);
    assert_eq!(rows.len() as u64, s.sent);
    assert_eq!(outcome_counts(&rows), counter_counts(&s));
    // Capacity drops name the unicast receiver; robot 0's inbox-full rows at tick 2 name
    // every sender past the first 16 in routing order.
    assert!(
        rows.iter()
            .any(|r| r.outcome == RadioOutcome::Capacity && r.to == Some(0))
    );
    let full: Vec<u32> = rows
        .iter()
        .filter(|r| r.tick == 2 && r.to == Some(0) && r.outcome == RadioOutcome::InboxFull)
        .map(|r| r.from)
        .collect();
    let expected: Vec<u32> = (17..=40).flat_map(|i| [i, i]).collect();
    assert_eq!(full, expected);
}

#[test]
fn accounting_invariant_holds_in_random_scenarios() {
    let mut totals = RadioStats::default();
    for scenario in 0..60 {
        let (_, s) = random_run(scenario, scenario + 1000);
        totals.dropped_loss += s.dropped_loss;
        totals.dropped_capacity += s.dropped_capacity;
        totals.dropped_out_of_range += s.dropped_out_of_range;
        totals.dropped_line_of_sight += s.dropped_line_of_sight;
        totals.dropped_receiver_down += s.dropped_receiver_down;
        totals.dropped_inbox_full += s.dropped_inbox_full;
        totals.delivered += s.delivered;
    }
    // The scenarios exercise every path (inbox_full needs dense, chatty scenarios).
    assert!(totals.delivered > 0);
    assert!(totals.dropped_inbox_full > 0);
    assert!(totals.dropped_loss > 0);
    assert!(totals.dropped_capacity > 0);
    assert!(totals.dropped_out_of_range > 0);
    assert!(totals.dropped_line_of_sight > 0);
    assert!(totals.dropped_receiver_down > 0);
}

#[test]
fn same_seed_same_inboxes_other_seed_other_losses() {
    for scenario in [3u64, 8, 21] {
        let (a, sa) = random_run(scenario, 5);
        let (b, sb) = random_run(scenario, 5);
        assert!(a == b, "scenario {scenario}: same seed, different inboxes");
        assert_eq!(sa, sb);
    }
    let cfg = RadioConfig {
        loss: 0.5,
        ..base_cfg()
    };
    let pos = [(0.0, 0.0), (1.0, 0.0)];
    let talk = [true, true];
    let out = vec![(0..4).map(|k| frame(BROADCAST, k)).collect(), Vec::new()];
    let losses = |seed: u64| {
        let mut m = RadioMedium::new(cfg, seed, 2);
        (0..50u64)
            .map(|t| {
                send(&mut m, t, &out, &pos, &talk);
                deliver(&mut m, t + 1, &talk)[1]
                    .iter()
                    .map(tag)
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(losses(1), losses(1));
    assert_ne!(losses(1), losses(2));
}

#[test]
fn odd_ranges_and_positions_route_like_brute_force() {
    // Infinite, zero, negative zero, negative, NaN and huge ranges; coincident robots,
    // robots at infinity and at NaN (never receivers; senders that hear only what the exact
    // distance says).
    let pos = [
        (0.0, 0.0),
        (0.0, 0.0),
        (3.0, 4.0),
        (1e3, -1e3),
        (f64::INFINITY, 0.0),
        (f64::NAN, 1.0),
        (0.0, f64::NEG_INFINITY),
        (-2.0, 0.5),
    ];
    let n = pos.len();
    for range in [
        f64::INFINITY,
        0.0,
        -0.0,
        -1.0,
        f64::NAN,
        5.0,
        1e300,
        f64::MAX,
    ] {
        let talk = vec![true; n];
        let cfg = RadioConfig {
            range,
            line_of_sight: true,
            ..base_cfg()
        };
        let mut m = RadioMedium::new(cfg, 1, n);
        let out: Vec<Vec<Frame>> = (0..n).map(|_| vec![frame(BROADCAST, 0)]).collect();
        let refs: Vec<&[Frame]> = out.iter().map(|v| v.as_slice()).collect();
        let mut routed = Vec::new();
        m.send(0, &refs, &pos, &talk, &mut |a, b| {
            routed.push((a, b));
            false
        });
        let finite = |p: (f64, f64)| p.0.is_finite() && p.1.is_finite();
        let expected: Vec<(usize, usize)> = (0..n)
            .flat_map(|tx| (0..n).map(move |rx| (tx, rx)))
            .filter(|&(tx, rx)| tx != rx && finite(pos[rx]) && in_range(pos[tx], pos[rx], range))
            .collect();
        assert_eq!(routed, expected, "range {range}");
    }
}

/// A crowd big enough for the parallel send (when the machine has the cores), against the
/// same sends while recording, which always takes the one-thread path: the same inboxes in
/// the same order and the same counters, with unicasts to anyone, robots that stop talking,
/// full inboxes and a partition.
#[test]
fn a_crowd_routed_on_threads_matches_the_one_thread_path() {
    let n = PARALLEL_SEND_MIN + 300;
    for delay_ticks in [0, 2] {
        let cfg = RadioConfig {
            range: 6.0,
            delay_ticks,
            ..base_cfg()
        };
        let mut r = rng::stream(5, "radio-test-crowd", delay_ticks as u64);
        // Half a robot per square metre: ~55 within range.
        let side = (n as f64 / 0.5).sqrt();
        let pos: Vec<(f64, f64)> = (0..n)
            .map(|_| (r.random_range(0.0..side), r.random_range(0.0..side)))
            .collect();
        let mut threaded = RadioMedium::new(cfg, 9, n);
        let mut single = RadioMedium::new(cfg, 9, n);
        single.set_recording(true);
        for t in 0..12u64 {
            let talk: Vec<bool> = (0..n).map(|_| r.random::<f64>() < 0.95).collect();
            let groups = (t % 4 == 3).then(|| (0..n).map(|i| (i % 3) as u64).collect());
            threaded.set_groups(groups.clone());
            single.set_groups(groups);
            let out: Vec<Vec<Frame>> = (0..n)
                .map(|i| {
                    (0..r.random_range(0..=6u32))
                        .map(|k| {
                            let dst = if r.random::<f64>() < 0.7 {
                                BROADCAST
                            } else {
                                r.random_range(0..n as u32 + 5)
                            };
                            frame(dst, (t as u32) << 20 | (i as u32) << 4 | k)
                        })
                        .collect()
                })
                .collect();
            send(&mut threaded, t, &out, &pos, &talk);
            send(&mut single, t, &out, &pos, &talk);
            let a = deliver(&mut threaded, t + 1, &talk);
            let b = deliver(&mut single, t + 1, &talk);
            assert!(a == b, "tick {t}: an inbox differs");
            assert_eq!(threaded.stats(), single.stats(), "tick {t}");
        }
        assert!(threaded.stats().dropped_inbox_full > 0);
        assert!(threaded.stats().dropped_partition > 0);
    }
}
