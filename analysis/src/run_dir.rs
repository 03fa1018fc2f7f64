//! A run directory read back: `trajectory.csv` and `events.jsonl` as typed records (the
//! schema is `swarmrt_protocol::records`, written by the world).

use std::path::Path;

use anyhow::Context;
use std::collections::BTreeMap;

use serde_json::Value;
use swarmrt_protocol::records::{Columns, Event, Records};

use crate::plot::trajectory::RobotTrack;

/// Reads `trajectory.csv` and `events.jsonl` from a run directory.
pub fn read(dir: &Path) -> anyhow::Result<Records> {
    let text = |name: &str| {
        std::fs::read_to_string(dir.join(name))
            .with_context(|| format!("reading {}", dir.join(name).display()))
    };
    Records::parse(&text("trajectory.csv")?, &text("events.jsonl")?).map_err(anyhow::Error::msg)
}

/// Reads `trajectory.csv` back into one track per robot, in id order (for the plot).
pub fn read_tracks(dir: &Path) -> anyhow::Result<Vec<RobotTrack>> {
    read_tracks_in(dir, |r| (r.x, r.y))
}

/// [`read_tracks`] in the (y, z) plane, for the side view of an aerial run.
pub fn read_side_tracks(dir: &Path) -> anyhow::Result<Vec<RobotTrack>> {
    read_tracks_in(dir, |r| (r.y, r.z))
}

fn read_tracks_in(
    dir: &Path,
    plane: impl Fn(&swarmrt_protocol::records::Row) -> (f64, f64),
) -> anyhow::Result<Vec<RobotTrack>> {
    let path = dir.join("trajectory.csv");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let cols = Columns::from_header(lines.next().unwrap_or("")).map_err(anyhow::Error::msg)?;
    let mut tracks: BTreeMap<u32, RobotTrack> = BTreeMap::new();
    for row in lines.filter_map(|l| cols.parse(l)) {
        let t = tracks.entry(row.id).or_insert_with(|| RobotTrack {
            id: row.id,
            points: Vec::new(),
            final_state: row.state,
        });
        let p = plane(&row);
        if t.points.last() != Some(&p) {
            t.points.push(p);
        }
        t.final_state = row.state;
    }
    Ok(tracks.into_values().collect())
}

/// Reads `events.jsonl` as typed events; lines that are cut short or of a kind this build
/// does not know are skipped.
pub fn read_events(dir: &Path) -> anyhow::Result<Vec<Event<Value>>> {
    let path = dir.join("events.jsonl");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    Ok(text
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmrt_protocol::RobotState;
    use swarmrt_protocol::records::FaultKind;

    #[test]
    fn a_run_directory_reads_back_typed_and_by_column_name() {
        let dir = tempfile::tempdir().unwrap();
        // Columns in another order than the world writes them: found by name.
        std::fs::write(
            dir.path().join("trajectory.csv"),
            "id,tick,x,y,theta,v,omega,lidar,state\n0,0,1.0,1.0,0,0,0,1,active\n\
             1,0,2.0,1.0,0,0,0,1,active\n0,1,1.5,1.0,0,0,0,1,active\n\
             1,1,2.0,1.0,0,0,0,0,down\n0,2,1.5",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("events.jsonl"),
            "{\"event\":\"collision\",\"tick\":1,\"robot\":1}\n\
             {\"event\":\"fault\",\"tick\":1,\"fault\":\"restart\",\"robot\":0}\n\
             {\"event\":\"from_the_future\",\"tick\":1}\n{\"event\":\"reached\",\"ti",
        )
        .unwrap();
        let tracks = read_tracks(dir.path()).unwrap();
        assert_eq!(tracks.len(), 2);
        assert_eq!(tracks[0].points, vec![(1.0, 1.0), (1.5, 1.0)]);
        assert_eq!(tracks[1].final_state, RobotState::Down);
        let events = read_events(dir.path()).unwrap();
        assert_eq!(events.len(), 2, "unknown and cut lines skipped: {events:?}");
        assert!(matches!(
            events[1],
            Event::Fault {
                fault: FaultKind::Restart,
                robot: Some(0),
                ..
            }
        ));
        let rec = read(dir.path()).unwrap();
        assert_eq!(rec.ticks.len(), 2);
    }
}
