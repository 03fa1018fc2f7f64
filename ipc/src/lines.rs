//! The orchestrator and its children speak one JSON object per line over pipes
//! (`swarmrt_protocol::control`). Each end reads them on a small thread of its own.

use std::io::{BufRead, BufReader, Read};

use serde::de::DeserializeOwned;

/// Reads `reader` line by line on a thread of its own: each line that parses as `T` goes to
/// `deliver` (which returns false when nobody listens any more, ending the thread), a line
/// that does not is logged with `from` and skipped; at the end of the stream (or a read
/// error) `eof` runs.
pub fn read_json_lines<T, R>(
    reader: R,
    from: String,
    mut deliver: impl FnMut(T) -> bool + Send + 'static,
    eof: impl FnOnce() + Send + 'static,
) where
    T: DeserializeOwned,
    R: Read + Send + 'static,
{
    std::thread::spawn(move || {
        for line in BufReader::new(reader).lines() {
            let Ok(line) = line else { break };
            match serde_json::from_str::<T>(&line) {
                Ok(m) => {
                    if !deliver(m) {
                        return;
                    }
                }
                Err(e) => tracing::warn!("ignoring a line from {from}: {line:?} ({e})"),
            }
        }
        eof();
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parsed_lines_are_delivered_a_bad_one_is_skipped_and_eof_comes_last() {
        let input = "{\"n\":1}\nnot json\n{\"n\":2}\n";
        let (tx, rx) = crossbeam_channel::unbounded::<Option<u32>>();
        let eof = tx.clone();
        #[derive(serde::Deserialize)]
        struct M {
            n: u32,
        }
        read_json_lines(
            std::io::Cursor::new(input.as_bytes().to_vec()),
            "a test".into(),
            move |m: M| tx.send(Some(m.n)).is_ok(),
            move || {
                let _ = eof.send(None);
            },
        );
        let got: Vec<Option<u32>> = rx.iter().take(3).collect();
        assert_eq!(got, [Some(1), Some(2), None]);
    }

    #[test]
    fn a_refused_delivery_ends_the_reader_without_eof() {
        let (tx, rx) = crossbeam_channel::unbounded::<&str>();
        let eof = tx.clone();
        let (done_tx, done) = crossbeam_channel::bounded::<()>(0);
        read_json_lines(
            std::io::Cursor::new(b"1\n2\n3\n".to_vec()),
            "a test".into(),
            move |_: u32| {
                let _keep = &done_tx;
                false
            },
            move || {
                let _ = eof.send("eof");
            },
        );
        // The thread ended (its closures, holding `done_tx`, were dropped) and sent no EOF.
        assert!(done.recv().is_err());
        drop(tx);
        assert!(rx.recv().is_err());
    }
}
