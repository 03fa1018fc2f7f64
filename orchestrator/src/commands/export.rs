//! `swarm export`: a run directory in another format. `--mcap` writes it as MCAP with
//! Foxglove's schemas (`swarmrt_analysis::export::mcap`), for the Foxglove app, Lichtblick
//! and any MCAP reader.

use swarmrt_analysis::export::mcap::{BadInput, Summary, write_mcap};

use crate::cli::ExportArgs;
use crate::error::{SwarmError, SwarmResult};

/// Writes the run as MCAP; prints the file and its messages per channel, and on stderr what
/// a torn (crashed) run's export left out.
pub fn export(args: &ExportArgs) -> SwarmResult<()> {
    let summary =
        write_mcap(&args.run_dir, &args.mcap).map_err(|e| match e.downcast::<BadInput>() {
            Ok(bad) => SwarmError::User(bad.0),
            Err(e) => SwarmError::Internal(e),
        })?;
    for w in &summary.warnings {
        eprintln!("warning: {w}");
    }
    print!("{}", report(&summary));
    Ok(())
}

/// `wrote <file> (...)` and one line per channel: topic, schema, messages.
fn report(s: &Summary) -> String {
    let mut out = format!(
        "wrote {} ({} bytes, {} ticks, {} robots)\n",
        s.path.display(),
        s.bytes,
        s.ticks,
        s.robots
    );
    let topic_w = s.channels.iter().map(|c| c.topic.len()).max().unwrap_or(0);
    let schema_w = s.channels.iter().map(|c| c.schema.len()).max().unwrap_or(0);
    for c in &s.channels {
        out += &format!(
            "  {:topic_w$}  {:schema_w$}  {} messages\n",
            c.topic, c.schema, c.messages
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmrt_analysis::export::mcap::ChannelCount;

    #[test]
    fn the_report_names_the_file_and_counts_per_channel() {
        let s = Summary {
            path: "out.mcap".into(),
            bytes: 10,
            ticks: 2,
            robots: 3,
            channels: vec![
                ChannelCount {
                    topic: "/tf".into(),
                    schema: "foxglove.FrameTransforms".into(),
                    messages: 2,
                },
                ChannelCount {
                    topic: "/events".into(),
                    schema: "foxglove.Log".into(),
                    messages: 0,
                },
            ],
            warnings: vec![],
        };
        assert_eq!(
            report(&s),
            "wrote out.mcap (10 bytes, 2 ticks, 3 robots)\n  \
             /tf      foxglove.FrameTransforms  2 messages\n  \
             /events  foxglove.Log              0 messages\n"
        );
    }
}
