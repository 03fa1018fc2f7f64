//! `swarm check`: validate a config (including building its map) and print it resolved.

use crate::cli::CheckArgs;
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};

/// Prints the resolved config as TOML.
pub fn check(args: &CheckArgs) -> SwarmResult<()> {
    let cfg = load_config(&args.config, &args.set)?;
    print!("{}", cfg.to_toml());
    if let Some(path) = &args.hosts {
        let file = swarmrt_hosts::HostsFile::load(path, cfg.robots.count)?;
        println!(
            "\n# {}: the world listens on {}",
            path.display(),
            file.listen
        );
        let remote: u32 = file.hosts.iter().map(|h| h.robots.len() as u32).sum();
        println!("# beside the world: {} robots", cfg.robots.count - remote);
        for h in &file.hosts {
            println!(
                "# host {}: robots {}..{} via {:?}, connecting to {}",
                h.name, h.robots.start, h.robots.end, h.launcher, h.connect
            );
        }
        if !file.is_secure() {
            eprintln!("warning: {}", file.insecure_refusal(path));
        }
        let problems = swarmrt_hosts::certs::check(&file);
        if !problems.is_empty() {
            for p in &problems {
                eprintln!("error: {p}");
            }
            return Err(SwarmError::User(format!(
                "{}: {} problem(s) with the run's certificates (swarm certs {} makes them)",
                path.display(),
                problems.len(),
                path.display()
            )));
        }
        if file.is_secure() {
            println!("# certificates in {}: valid", file.certs.display());
        }
    }
    Ok(())
}
