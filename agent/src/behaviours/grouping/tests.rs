//! Seed 001's equations against hand-computed cases: the force sum (eq. 3-6), the quadrant
//! counts of the paper's Fig. 4 case, FRN ordering and the slots of eq. 8-9, the sectors of
//! eq. 12-13, ΔΩ (eq. 16) and the range-finder classifier.

use std::f64::consts::{FRAC_PI_2, PI};

use crate::behaviours::grouping::equations::*;
use crate::behaviours::grouping::metrics::delta_omega;
use crate::consensus::quadrant::{quadrant, score};
use swarmrt_protocol::Neighbour;

fn close(a: V2, b: V2) -> bool {
    (a - b).norm() < 1e-9
}

#[test]
fn the_force_sum_matches_hand_computed_cases() {
    // (sensed robots relative to the robot, G, cap) -> R_i A
    type Case<'a> = (&'a [(f64, f64)], f64, f64, (f64, f64));
    let cases: &[Case] = &[
        // One robot 1 m east: G / 1.
        (&[(1.0, 0.0)], 1.0, 10.0, (1.0, 0.0)),
        // 1 m east and 2 m north: (1, 0) + (0, 1/4).
        (&[(1.0, 0.0), (0.0, 2.0)], 1.0, 10.0, (1.0, 0.25)),
        // Equal and opposite pulls cancel.
        (&[(2.0, 0.0), (-2.0, 0.0)], 3.0, 10.0, (0.0, 0.0)),
        // 0.1 m away the pull 100 G is capped at 4.
        (&[(0.1, 0.0)], 1.0, 4.0, (4.0, 0.0)),
        // G scales it: 3 m south-west with G = 9 pulls 1 along the diagonal.
        (
            &[(-3.0 / 2f64.sqrt(), -3.0 / 2f64.sqrt())],
            9.0,
            10.0,
            (-(0.5f64.sqrt()), -(0.5f64.sqrt())),
        ),
    ];
    for (sensed, g, cap, want) in cases {
        let pts: Vec<V2> = sensed.iter().map(|&(x, y)| V2::new(x, y)).collect();
        let got = resultant(&pts, *g, *cap);
        assert!(
            close(got, V2::new(want.0, want.1)),
            "{sensed:?}: {got:?} != {want:?}"
        );
    }
    assert_eq!(pull(1.0, 2.0, 10.0), 0.25);
    // Clustered once the closest is within the threshold; alone never.
    assert!(clustered(&[V2::new(0.5, 0.0), V2::new(3.0, 0.0)], 0.8));
    assert!(!clustered(&[V2::new(0.9, 0.0)], 0.8));
    assert!(!clustered(&[], 0.8));
}

/// Bearings of the others in robot `i`'s frame (heading 0) as the range-and-bearing sensor
/// reports them.
fn view(pos: &[(f64, f64)], i: usize) -> Vec<Neighbour> {
    pos.iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(j, q)| Neighbour {
            id: j as u32,
            range: ((q.0 - pos[i].0).powi(2) + (q.1 - pos[i].1).powi(2)).sqrt(),
            bearing: (q.1 - pos[i].1).atan2(q.0 - pos[i].0),
        })
        .collect()
}

#[test]
fn fig_4_only_the_upper_left_robot_sees_the_group_in_one_quadrant() {
    // Fig. 4: the robot at the upper left sees the other three in its fourth quadrant
    // ([-90°, 0°)); every other robot sees them spread over two or more quadrants.
    let pos = [(0.0, 2.0), (1.5, 1.2), (2.5, 0.4), (1.0, 0.0)];
    let counts = |i: usize| {
        let mut c = [0; 4];
        for n in view(&pos, i) {
            c[quadrant(n.bearing)] += 1;
        }
        c
    };
    assert_eq!(counts(0), [0, 0, 0, 3]);
    let scores: Vec<u8> = (0..4).map(|i| score(&view(&pos, i))).collect();
    assert_eq!(scores[0], 3);
    assert!(scores[1..].iter().all(|&s| s < 3), "{scores:?}");
    // The quadrant of a bearing: counter-clockwise from the heading, half open.
    let table = [
        (0.0, 0),
        (FRAC_PI_2, 1),
        (PI, 2),
        (-PI, 2),
        (-FRAC_PI_2, 3),
        (-0.01, 3),
    ];
    for (b, q) in table {
        assert_eq!(quadrant(b), q, "bearing {b}");
    }
}

#[test]
fn frn_counts_counter_clockwise_from_the_leader_and_slots_follow_eq_8_9() {
    let cog = V2::new(0.0, 0.0);
    // Leader east of the COG; members north, south and west, given out of order.
    let members = [
        (7, V2::new(0.0, -1.0)),
        (3, V2::new(-1.0, 0.0)),
        (5, V2::new(0.0, 1.0)),
    ];
    let order = frn_order((1, V2::new(1.0, 0.0)), &members, cog);
    assert_eq!(order, [1, 5, 3, 7]);
    assert!((c_diff(V2::new(1.0, 0.0), cog)).abs() < 1e-12);
    // Leader north of the COG: c_diff 90°, west is next counter-clockwise.
    let order = frn_order(
        (5, V2::new(0.0, 1.0)),
        &[(1, V2::new(1.0, 0.0)), (3, V2::new(-1.0, 0.0))],
        cog,
    );
    assert_eq!(order, [5, 3, 1]);
    // Eq. 8-9 (eq. 9 with sin): (c, f_r, n, frn, c_diff) -> slot.
    let c = V2::new(2.0, 3.0);
    let table: &[(usize, usize, f64, (f64, f64))] = &[
        (4, 0, 0.0, (4.0, 3.0)),
        (4, 1, 0.0, (2.0, 5.0)),
        (4, 2, 0.0, (0.0, 3.0)),
        (4, 3, 0.0, (2.0, 1.0)),
        (4, 1, FRAC_PI_2, (0.0, 3.0)),
        (
            3,
            1,
            0.0,
            (
                2.0 + 2.0 * (2.0 * PI / 3.0).cos(),
                3.0 + 2.0 * (2.0 * PI / 3.0).sin(),
            ),
        ),
    ];
    for &(n, frn, cd, want) in table {
        assert!(
            close(slot(c, 2.0, n, frn, cd), V2::new(want.0, want.1)),
            "n {n} frn {frn}"
        );
    }
    let three = [V2::new(0.0, 0.0), V2::new(2.0, 0.0), V2::new(1.0, 3.0)];
    assert!(close(
        crate::behaviours::grouping::equations::cog(&three),
        V2::new(1.0, 1.0)
    ));
}

#[test]
fn potential_field_attracts_to_the_slot_and_repels_near_obstacles_only() {
    assert!(close(
        attraction(2.0, V2::new(1.0, 1.0), V2::new(2.0, 1.0)),
        V2::new(2.0, 0.0)
    ));
    // An obstacle 0.5 m east inside rho_0 = 1: pushed west by k (1/0.5 - 1) / 0.25 = 4 k.
    let f = repulsion(0.1, 1.0, &[V2::new(0.5, 0.0)]);
    assert!(close(f, V2::new(-0.4, 0.0)), "{f:?}");
    assert!(close(
        repulsion(0.1, 1.0, &[V2::new(1.5, 0.0)]),
        V2::zeros()
    ));
    // The swirl: an obstacle dead ahead of where the robot wants to go adds a sideways push
    // toward the side the wish leans to; one behind adds none.
    let ahead = repulsion_swirl(0.1, 1.0, &[V2::new(0.5, 0.0)], V2::new(1.0, 0.1));
    assert!(close(ahead, V2::new(-0.4, 0.4)), "{ahead:?}");
    let behind = repulsion_swirl(0.1, 1.0, &[V2::new(-0.5, 0.0)], V2::new(1.0, 0.0));
    assert!(close(behind, V2::new(0.4, 0.0)), "{behind:?}");
}

#[test]
fn eq_12_13_split_the_plane_into_one_sector_per_group() {
    // Three groups at 90°, 210° and 330° about the origin, 10 m out.
    let at = |deg: f64| V2::new(10.0 * deg.to_radians().cos(), 10.0 * deg.to_radians().sin());
    let (a, b, c) = (at(90.0), at(210.0), at(330.0));
    assert!(close(partial(a, b), (a + b) / 2.0));
    let s = sector(a, &[b, c]);
    assert!(s.apex.norm() < 1e-9, "X is the COG of all groups");
    // Partial COGs with the right (330°) and left (210°) neighbours lie at 30° and 150°.
    assert!(
        (s.alpha - 30f64.to_radians()).abs() < 1e-9,
        "{}",
        s.alpha.to_degrees()
    );
    assert!((s.beta() - 150f64.to_radians()).abs() < 1e-9);
    assert!((s.span - 120f64.to_radians()).abs() < 1e-9);
    // The three sectors tile the circle.
    let spans: f64 = [sector(a, &[b, c]), sector(b, &[a, c]), sector(c, &[a, b])]
        .iter()
        .map(|s| s.span)
        .sum();
    assert!((spans - 2.0 * PI).abs() < 1e-9);
    // Eq. 13: every draw lies in the sector, within r of X.
    for k in 0..50 {
        let (u, v) = (k as f64 / 50.0, ((k * 7) % 50) as f64 / 50.0);
        let p = s.point(6.0, u, v);
        assert!(p.norm() <= 6.0 + 1e-9);
        assert!(p.norm() < 1e-9 || s.contains(p.y.atan2(p.x)), "{p:?}");
    }
    // One group searches all around itself; two split the plane between them.
    assert!((sector(a, &[]).span - 2.0 * PI).abs() < 1e-12);
    let two = sector(V2::new(0.0, 5.0), &[V2::new(0.0, -5.0)]);
    assert!((two.span - PI).abs() < 1e-12);
    assert!(two.contains(FRAC_PI_2) && !two.contains(-FRAC_PI_2));
}

#[test]
fn delta_omega_of_eq_16_on_a_known_sequence() {
    // Turn rates 0, 1, 1, 3 rad/s over cycles of 0.1 s: |ΔΩ| = 10, 0, 20 rad/s^2, mean 10.
    let headings = [0.0, 0.0, 0.1, 0.2, 0.5];
    assert!((delta_omega(&headings, 0.1) - 10f64.to_degrees()).abs() < 1e-9);
    // A steady turn (also across ±pi) has none.
    let steady: Vec<f64> = (0..40)
        .map(|k| ((k as f64 * 0.3 + PI) % (2.0 * PI)) - PI)
        .collect();
    assert!(delta_omega(&steady, 0.1).abs() < 1e-6);
    assert_eq!(delta_omega(&[1.0, 2.0], 0.1), 0.0);
}

/// A 64-ray, 360° scan from the origin (heading 0) of circles and one wall at x = `wall`.
fn scan(circles: &[(f64, f64, f64)], wall: Option<f64>, range: f64) -> (Vec<f64>, Vec<f64>) {
    let angles: Vec<f64> = (0..64).map(|k| -PI + 2.0 * PI * k as f64 / 64.0).collect();
    let ranges = angles
        .iter()
        .map(|&a| {
            let d = V2::new(a.cos(), a.sin());
            let mut best = range;
            for &(x, y, r) in circles {
                let c = V2::new(x, y);
                let t = c.dot(&d);
                let h2 = c.norm_squared() - t * t;
                if t > 0.0 && h2 <= r * r {
                    best = best.min(t - (r * r - h2).sqrt());
                }
            }
            if let Some(w) = wall
                && d.x > 1e-9
            {
                best = best.min(w / d.x);
            }
            best
        })
        .collect();
    (ranges, angles)
}

#[test]
fn the_classifier_tells_robot_arcs_from_cones_and_walls() {
    let cl = Classifier {
        radius: 0.2,
        range: 4.0,
        tolerance: 0.05,
    };
    // A robot 1.5 m north, a cone of radius 0.6 3 m south, a wall 2 m east.
    let (ranges, angles) = scan(&[(0.0, 1.5, 0.2), (0.0, -3.0, 0.6)], Some(2.0), 4.0);
    let blobs = cl.blobs(&ranges, &angles, true);
    let robots: Vec<&Blob> = blobs.iter().filter(|b| b.robot).collect();
    assert_eq!(robots.len(), 1, "{blobs:?}");
    assert!(
        (robots[0].centre - V2::new(0.0, 1.5)).norm() < 0.1,
        "{:?}",
        robots[0].centre
    );
    assert!(
        blobs.iter().filter(|b| !b.robot).count() >= 2,
        "cone and wall"
    );
    // Precision (eq. 17) against the truth: one right; a robot blob with no robot there is
    // wrong; blobs beyond the judged range are not counted.
    let truth = [V2::new(0.0, 1.5)];
    assert_eq!(matches(&blobs, &truth, 4.0, 0.4), (1, 0));
    assert_eq!(matches(&blobs, &[], 4.0, 0.4), (0, 1));
    assert_eq!(matches(&blobs, &[], 1.0, 0.4), (0, 0));
    // Two robots side by side 1 m apart are two robots, and the cyclic scan joins the
    // cluster that straddles ray 0 (a robot due west, at -180°).
    let (ranges, angles) = scan(
        &[(1.0, 1.0, 0.2), (1.0, 0.0, 0.2), (-2.0, 0.0, 0.2)],
        None,
        4.0,
    );
    let blobs = cl.blobs(&ranges, &angles, true);
    assert_eq!(blobs.iter().filter(|b| b.robot).count(), 3, "{blobs:?}");
}
