//! `swarm view`: serve a run's replay (or live view) in the browser until Ctrl-C.

use crate::cli::{ServeArgs, ViewArgs};
use crate::error::{SwarmError, SwarmResult};

/// A directory that is not a run or a port in use is the user's to fix (one line, exit 2).
fn user_error(e: swarmrt_viewer::ViewError) -> SwarmError {
    match e {
        swarmrt_viewer::ViewError::Start(io) => SwarmError::Internal(io.into()),
        e => SwarmError::User(e.to_string()),
    }
}

/// Takes the page's port (before a run writes anything).
pub fn bind(serve: &ServeArgs) -> SwarmResult<std::net::TcpListener> {
    if !serve.listen.is_loopback() {
        eprintln!(
            "warning: listening on {}: the page asks for the token in the URL printed below; \
             anyone who has that URL can watch the run",
            serve.listen
        );
    }
    swarmrt_viewer::Viewer::bind(&swarmrt_viewer::Listen {
        ip: serve.listen,
        port: serve.port,
    })
    .map_err(user_error)
}

/// Starts the viewer for `dir` on a socket from [`bind`].
pub fn start(
    dir: &std::path::Path,
    socket: std::net::TcpListener,
) -> SwarmResult<swarmrt_viewer::Viewer> {
    swarmrt_viewer::Viewer::serve(dir, socket).map_err(user_error)
}

/// Serves the page until Ctrl-C; prints its address first.
pub fn view(args: &ViewArgs, interrupt: crossbeam_channel::Receiver<()>) -> SwarmResult<()> {
    let viewer = start(&args.run_dir, bind(&args.serve)?)?;
    println!("{}", viewer.url());
    eprintln!("serving {} until Ctrl-C", args.run_dir.display());
    let _ = interrupt.recv();
    viewer.stop();
    Ok(())
}
