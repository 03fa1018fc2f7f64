//! The formation's rules (seed 000) as tables: observer selection from the cases of the
//! paper's Fig. 5 and Fig. 6, section 5.2's turn table, and epsilon-greedy's flip rates.

use crate::behaviours::formation::direction::{self, Dir, Seen};
use crate::behaviours::formation::observers::{self, Observers, Placed, to_leader_frame};
use swarmrt_scenario::rng;

/// Half a robot width: differences below it count as equal.
const TOL: f64 = 0.15;

/// Side ranges this close count as equal (the formation's default `gap_tie`).
const TIE_M: f64 = 0.05;

fn placed(robots: &[(u32, f64, f64)]) -> Vec<Placed> {
    robots
        .iter()
        .map(|&(id, x, y)| Placed { id, x, y })
        .collect()
}

fn obs(middle: Option<u32>, left: Option<u32>, right: Option<u32>) -> Observers {
    Observers {
        middle,
        left,
        right,
    }
}

#[test]
fn observer_selection_follows_the_papers_cases() {
    /// (name, robots as (id, x', y'), expected observers)
    type Case<'a> = (&'a str, &'a [(u32, f64, f64)], Observers);
    let cases: &[Case] = &[
        (
            // Fig. 5: 3 and 4 share the largest x', 3 is nearer the axis -> middle. 1 and 2
            // share the largest y', 2 is further ahead -> left. 6 has the smallest y' but only
            // by less than half a width; 5 is further ahead -> right.
            "fig 5",
            &[
                (1, 0.0, 1.0),
                (2, 0.5, 1.0),
                (3, 1.0, 0.1),
                (4, 1.0, -0.6),
                (5, 0.6, -1.0),
                (6, 0.0, -1.1),
                (7, -0.5, 0.0),
            ],
            obs(Some(3), Some(2), Some(5)),
        ),
        (
            // Fig. 6: 5 meets the middle and the right criteria: it is the right observer and
            // the next one meeting the middle criterion, 4, is the middle.
            "fig 6",
            &[
                (1, 0.2, 1.0),
                (2, -0.4, 0.4),
                (3, -0.6, -0.3),
                (4, 0.8, 0.0),
                (5, 1.0, -1.0),
                (6, -0.5, -0.5),
            ],
            obs(Some(4), Some(1), Some(5)),
        ),
        (
            // The same, mirrored: a robot that is both middle and left takes the left role.
            "fig 6 mirrored",
            &[(1, 0.2, -1.0), (4, 0.8, 0.0), (5, 1.0, 1.0), (6, -0.5, 0.5)],
            obs(Some(4), Some(5), Some(1)),
        ),
        (
            // x' 1.0 against 0.9 differs by less than half a width: equal, so |y'| decides.
            "tolerance on x'",
            &[(1, 1.0, 0.5), (2, 0.9, 0.0), (3, 0.0, 1.5), (4, 0.0, -1.5)],
            obs(Some(2), Some(3), Some(4)),
        ),
        (
            "one robot left: middle",
            &[(7, 0.0, 0.0)],
            obs(Some(7), None, None),
        ),
        (
            "two robots left: left and right",
            &[(1, 0.3, -0.4), (2, 0.1, 0.4)],
            obs(None, Some(2), Some(1)),
        ),
        ("nobody", &[], obs(None, None, None)),
    ];
    for (name, robots, want) in cases {
        assert_eq!(observers::select(&placed(robots), TOL), *want, "{name}");
    }
}

#[test]
fn a_3x3_grid_heading_east_has_the_front_row_as_observers() {
    // Ids row by row from the front (x = 1) to the back (x = -1), left (y = 1) to right.
    let mut robots = Vec::new();
    for (row, x) in [1.0, 0.0, -1.0].into_iter().enumerate() {
        for (col, y) in [1.0, 0.0, -1.0].into_iter().enumerate() {
            robots.push(((row * 3 + col) as u32, x, y));
        }
    }
    assert_eq!(
        observers::select(&placed(&robots), TOL),
        obs(Some(1), Some(0), Some(2))
    );
    // Heading north instead (omega = 90 degrees) in world coordinates: the robots with the
    // largest world y lead, and the left side is the one with the smallest world x.
    let world: Vec<Placed> = robots
        .iter()
        .map(|&(id, x, y)| {
            let (xp, yp) = to_leader_frame(-y, x, (0.0, 0.0), std::f64::consts::FRAC_PI_2);
            Placed { id, x: xp, y: yp }
        })
        .collect();
    assert_eq!(
        observers::select(&world, TOL),
        obs(Some(1), Some(0), Some(2))
    );
}

#[test]
fn eq_4_5_rotate_into_the_leader_frame() {
    let (x, y) = to_leader_frame(3.0, 4.0, (1.0, 1.0), 0.0);
    assert!((x - 2.0).abs() < 1e-12 && (y - 3.0).abs() < 1e-12);
    // Heading 90 degrees: a robot north of the leader is ahead, one east of it is right.
    let (x, y) = to_leader_frame(1.0, 3.0, (1.0, 1.0), std::f64::consts::FRAC_PI_2);
    assert!((x - 2.0).abs() < 1e-12 && y.abs() < 1e-12);
    let (x, y) = to_leader_frame(3.0, 1.0, (1.0, 1.0), std::f64::consts::FRAC_PI_2);
    assert!(x.abs() < 1e-12 && (y + 2.0).abs() < 1e-12);
}

#[test]
fn the_turn_table_of_section_5_2() {
    let half = 0.05;
    let s = Seen::flags;
    let heads = || panic!("no coin needed here");
    // (seen, previous, target error, expected)
    let table: &[(Seen, Dir, f64, Dir)] = &[
        // Nothing seen: toward the target.
        (s(false, false, false), Dir::Right, 1.0, Dir::Left),
        (s(false, false, false), Dir::Left, -1.0, Dir::Right),
        (s(false, false, false), Dir::Left, 0.01, Dir::Straight),
        // Left, or left and middle: right.
        (s(true, false, false), Dir::Left, 1.0, Dir::Right),
        (s(true, true, false), Dir::Straight, 1.0, Dir::Right),
        // Right, or middle and right: left.
        (s(false, false, true), Dir::Right, -1.0, Dir::Left),
        (s(false, true, true), Dir::Straight, -1.0, Dir::Left),
        // Only the middle, or all: keep the previous turn ...
        (s(false, true, false), Dir::Left, -1.0, Dir::Left),
        (s(true, true, true), Dir::Right, 1.0, Dir::Right),
        // ... after going straight, toward the target.
        (s(false, true, false), Dir::Straight, 1.0, Dir::Left),
        (s(true, true, true), Dir::Straight, -1.0, Dir::Right),
    ];
    // Left and right only (a gap ahead; the paper is silent, the reading is ours): away from
    // the nearer side whatever the previous turn or the target says; equal ranges (to the
    // radio's decimetre) go straight through.
    let gap = |left_range, right_range| Seen {
        left_range,
        right_range,
        ..s(true, false, true)
    };
    let gap_table: &[(Seen, Dir, f64, Dir)] = &[
        (gap(1.2, 2.5), Dir::Left, 1.0, Dir::Right),
        (gap(1.2, 2.5), Dir::Straight, 0.0, Dir::Right),
        (gap(2.9, 1.3), Dir::Right, -1.0, Dir::Left),
        (gap(2.9, 2.8), Dir::Straight, -1.0, Dir::Left),
        (gap(2.0, 2.0), Dir::Left, 1.0, Dir::Straight),
        (gap(2.0, 2.0), Dir::Right, -1.0, Dir::Straight),
    ];
    for &(seen, previous, err, want) in table.iter().chain(gap_table) {
        assert_eq!(
            direction::decide(seen, previous, err, half, TIE_M, heads),
            want,
            "{seen:?} after {previous:?}, target error {err}"
        );
    }
    // Heading straight at the target with an obstacle dead ahead: the coin picks the side.
    for (coin, want) in [(true, Dir::Left), (false, Dir::Right)] {
        assert_eq!(
            direction::decide(
                s(false, true, false),
                Dir::Straight,
                0.0,
                half,
                TIE_M,
                || coin
            ),
            want
        );
    }
}

#[test]
fn side_ranges_travel_in_whole_decimetres() {
    use crate::behaviours::formation::{range_from_wire, range_to_wire};
    assert_eq!(range_to_wire(None), 0, "nothing seen");
    assert_eq!(range_from_wire(0), None);
    assert_eq!(range_to_wire(Some(2.94)), 29);
    assert_eq!(range_from_wire(29), Some(2.9));
    // Seen at all is never sent as nothing seen, and far ranges saturate.
    assert_eq!(range_to_wire(Some(0.0)), 1);
    assert_eq!(range_to_wire(Some(40.0)), 255);
}

#[test]
fn epsilon_greedy_flips_at_its_rates() {
    // 1 % with nothing seen, 0.1 % with an obstacle seen: over n draws the count of flips
    // must lie within 5 standard deviations of n * eps.
    let n = 200_000u32;
    for (seen, eps) in [
        (Seen::default(), 0.01),
        (
            Seen {
                middle: true,
                ..Seen::default()
            },
            0.001,
        ),
    ] {
        let mut rng = rng::stream(7, "formation-epsilon", 3);
        let mut flips = 0u32;
        for _ in 0..n {
            let (dir, flipped) = direction::epsilon_greedy(Dir::Left, seen, 0.001, 0.01, &mut rng);
            assert_eq!(dir == Dir::Right, flipped, "a flip is the opposite turn");
            flips += flipped as u32;
        }
        let mean = n as f64 * eps;
        let sd = (n as f64 * eps * (1.0 - eps)).sqrt();
        assert!(
            (flips as f64 - mean).abs() < 5.0 * sd,
            "eps {eps}: {flips} flips in {n}, expected {mean} +- {}",
            5.0 * sd
        );
    }
    // Going straight has no opposite: never flipped.
    let mut rng = rng::stream(7, "formation-epsilon", 3);
    for _ in 0..1000 {
        let (dir, flipped) =
            direction::epsilon_greedy(Dir::Straight, Seen::default(), 1.0, 1.0, &mut rng);
        assert_eq!((dir, flipped), (Dir::Straight, false));
    }
}
