//! The trajectory figure: files written, equal scale, tick labels, degenerate inputs.

use super::*;
use swarmrt_scenario::{CircleObstacle, PolygonObstacle, RectObstacle};

/// A small scenario with one obstacle of each kind.
fn config(bounds: [f64; 4]) -> Config {
    let [x0, y0, x1, y1] = bounds;
    let text = format!(
        r#"
[scenario]
name = "plot-test"
seed = 42
ticks = 10

[map]
bounds = [{x0:?}, {y0:?}, {x1:?}, {y1:?}]
goal = {{ x = {gx:?}, y = {gy:?}, radius = 1.0 }}

[robots]
count = 3
radius = 0.2
"#,
        gx = x1 - (x1 - x0) * 0.1,
        gy = y1 - (y1 - y0) * 0.2,
    );
    let mut cfg = Config::from_toml_str("plot-test.toml", &text, &[]).expect("test config");
    cfg.map.circles.push(CircleObstacle {
        x: x0 + (x1 - x0) * 0.5,
        y: y0 + (y1 - y0) * 0.5,
        r: (y1 - y0) * 0.1,
        height: None,
    });
    cfg.map.rectangles.push(RectObstacle {
        x_min: x0 + (x1 - x0) * 0.25,
        y_min: y0 + (y1 - y0) * 0.1,
        x_max: x0 + (x1 - x0) * 0.3,
        y_max: y0 + (y1 - y0) * 0.4,
        height: None,
    });
    cfg.map.polygons.push(PolygonObstacle {
        points: vec![
            [x0 + (x1 - x0) * 0.65, y0 + (y1 - y0) * 0.7],
            [x0 + (x1 - x0) * 0.75, y0 + (y1 - y0) * 0.7],
            [x0 + (x1 - x0) * 0.7, y0 + (y1 - y0) * 0.9],
        ],
        height: None,
    });
    cfg
}

/// Three paths from the lower left towards the goal, in map fractions scaled to `cfg`.
fn three_tracks(cfg: &Config) -> Vec<RobotTrack> {
    let [x0, y0, x1, y1] = cfg.map.bounds;
    let path = |sx: f64, sy: f64, ex: f64, ey: f64, n: usize| -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let t = k as f64 / (n - 1) as f64;
                let fx = sx + (ex - sx) * t;
                let fy = sy + (ey - sy) * t + (t * 9.0).sin() * 0.04;
                (x0 + fx * (x1 - x0), y0 + fy * (y1 - y0))
            })
            .collect()
    };
    vec![
        RobotTrack {
            id: 0,
            points: path(0.08, 0.15, 0.88, 0.78, 80),
            final_state: RobotState::Active,
        },
        RobotTrack {
            id: 1,
            points: path(0.08, 0.25, 0.55, 0.55, 50),
            final_state: RobotState::Down,
        },
        RobotTrack {
            id: 2,
            points: path(0.14, 0.2, 0.6, 0.25, 60),
            final_state: RobotState::Dead,
        },
    ]
}

/// Width and height from the PNG IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    (w, h)
}

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];

fn render(cfg: &Config, tracks: &[RobotTrack]) -> (String, Vec<u8>) {
    let dir = tempfile::tempdir().unwrap();
    let out = OutDir::open(dir.path()).unwrap();
    let svg = dir.path().join("trajectories.svg");
    let png = dir.path().join("trajectories.png");
    write_trajectory_plots(cfg, tracks, &out, "trajectories").unwrap();
    (
        std::fs::read_to_string(&svg).unwrap(),
        std::fs::read(&png).unwrap(),
    )
}

#[test]
fn plot_writes_svg_and_png() {
    let cfg = config([0.0, 0.0, 20.0, 10.0]);
    let tracks = three_tracks(&cfg);
    let (svg, png) = render(&cfg, &tracks);

    assert!(svg.contains("<svg"));
    assert!(svg.contains("plot-test seed 42: 3 robots"));
    assert!(svg.contains("x (m)") && svg.contains("y (m)"));
    // Each track is drawn as a polyline in its own colour.
    for i in 0..tracks.len() {
        let c = track_colour(i);
        let stroke = format!("stroke=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2);
        let found = svg
            .split('<')
            .any(|el| el.starts_with("polyline") && el.contains(&stroke));
        assert!(found, "no polyline with {stroke} for track {i}");
    }

    assert_eq!(png[..8], PNG_SIGNATURE);
    // A wide map: the width is the long side.
    let (w, h) = png_size(&png);
    assert_eq!(w, LONG_SIDE);
    assert!(h < w, "height {h} for a 2:1 map");
}

#[test]
fn plot_tall_map_keeps_long_side_vertical() {
    let cfg = config([-5.0, -10.0, 5.0, 10.0]);
    let (_, png) = render(&cfg, &three_tracks(&cfg));
    assert_eq!(png[..8], PNG_SIGNATURE);
    let (w, h) = png_size(&png);
    assert_eq!(h, LONG_SIDE);
    assert!(w < h, "width {w} for a 1:2 map");
}

#[test]
fn plot_layout_keeps_equal_scale() {
    let cfg = config([0.0, 0.0, 20.0, 10.0]);
    crate::plot::ensure_font().unwrap();
    let lay = layout(&cfg, &three_tracks(&cfg));
    let sx = f64::from(lay.plot_w) / (lay.x.1 - lay.x.0);
    let sy = f64::from(lay.plot_h) / (lay.y.1 - lay.y.0);
    assert!((sx - sy).abs() / sx < 1e-9, "x scale {sx} vs y scale {sy}");
    assert!(lay.x.0 < 0.0 && lay.x.1 > 20.0 && lay.y.0 < 0.0 && lay.y.1 > 10.0);
}

#[test]
fn plot_tick_labels() {
    assert_eq!(tick_label(2.0, 20.0, 20.0), "2");
    assert_eq!(tick_label(0.5, 5.0, 5.0), "0.5");
    assert_eq!(tick_label(-0.0, 5.0, 5.0), "0.0");
    assert_eq!(tick_label(1.5e6, 4e6, 3e6), "1.5e6");
    assert_eq!(tick_label(-1e6, 4e6, 3e6), "-1e6");
    assert_eq!(tick_label(0.0, 4e6, 3e6), "0");
}

#[test]
fn plot_unwritable_path_is_an_error() {
    let cfg = config([0.0, 0.0, 20.0, 10.0]);
    let dir = tempfile::tempdir().unwrap();
    let tracks = three_tracks(&cfg);
    // A link planted at either name is refused, and its target left alone.
    let out = OutDir::open(dir.path()).unwrap();
    let target = dir.path().join("target");
    std::fs::write(&target, "keep").unwrap();
    for name in ["a.svg", "b.png"] {
        std::os::unix::fs::symlink(&target, dir.path().join(name)).unwrap();
    }
    assert!(write_trajectory_plots(&cfg, &tracks, &out, "a").is_err());
    assert!(write_trajectory_plots(&cfg, &tracks, &out, "b").is_err());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
    // A directory gone since it was opened takes no plot.
    let gone = dir.path().join("gone");
    std::fs::create_dir(&gone).unwrap();
    let out = OutDir::open(&gone).unwrap();
    std::fs::remove_dir(&gone).unwrap();
    assert!(write_trajectory_plots(&cfg, &tracks, &out, "c").is_err());
}

#[test]
fn plot_zero_tracks() {
    let cfg = config([0.0, 0.0, 20.0, 10.0]);
    let (svg, png) = render(&cfg, &[]);
    assert!(svg.contains("plot-test seed 42: 0 robots"));
    assert_eq!(png[..8], PNG_SIGNATURE);
}

#[test]
fn plot_many_tracks_and_degenerate_ones() {
    let cfg = config([0.0, 0.0, 20.0, 10.0]);
    let mut tracks: Vec<RobotTrack> = (0..300u32)
        .map(|id| {
            let y = 0.2 + f64::from(id) * 0.03;
            RobotTrack {
                id,
                points: (0..40).map(|k| (1.0 + f64::from(k) * 0.4, y)).collect(),
                final_state: match id % 3 {
                    0 => RobotState::Active,
                    1 => RobotState::Down,
                    _ => RobotState::Dead,
                },
            }
        })
        .collect();
    tracks.push(RobotTrack {
        id: 300,
        points: vec![(5.0, 5.0)],
        final_state: RobotState::Active,
    });
    tracks.push(RobotTrack {
        id: 301,
        points: vec![],
        final_state: RobotState::Dead,
    });
    let (svg, png) = render(&cfg, &tracks);
    assert!(svg.contains("302 robots"));
    assert!(svg.matches("<polyline").count() >= 301);
    assert_eq!(png[..8], PNG_SIGNATURE);
}

#[test]
fn plot_large_coordinates() {
    let mut cfg = config([0.0, 0.0, 20.0, 10.0]);
    cfg.map.bounds = [-1e9, -1e9, 1e9, 1e9];
    let tracks = vec![RobotTrack {
        id: 0,
        points: vec![(-5e8, 0.0), (3e9, 2e9)],
        final_state: RobotState::Down,
    }];
    let (_, png) = render(&cfg, &tracks);
    assert_eq!(png[..8], PNG_SIGNATURE);
    let (w, h) = png_size(&png);
    assert_eq!(w.max(h), LONG_SIDE);
}
