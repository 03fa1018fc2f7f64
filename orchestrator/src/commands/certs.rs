//! `swarm certs`: the certificates of a multi-host run, in one command.

use crate::cli::CertsArgs;
use crate::error::{SwarmError, SwarmResult};

/// Writes the CA, the world's and every host's certificate and key for `args.hosts`.
pub fn certs(args: &CertsArgs) -> SwarmResult<()> {
    // Robot ids do not matter here: any count large enough for the file's ranges.
    let file = swarmrt_hosts::HostsFile::load(&args.hosts, u32::MAX)?;
    let out = args.out.clone().unwrap_or_else(|| file.certs.clone());
    let written = swarmrt_hosts::certs::generate(&file, &out)
        .map_err(|e| SwarmError::User(format!("swarm certs: {e}")))?;
    for p in &written {
        println!("{}", p.display());
    }
    println!(
        "# the world's certificate names {:?}; copy ca.pem and host-<name>.pem/.key to each host's certs directory (keep ca.key here)",
        swarmrt_hosts::certs::world_names(&file)
    );
    if out != file.certs {
        println!(
            "# set world.certs = {:?} in {} to use them",
            out.display().to_string(),
            args.hosts.display()
        );
    }
    Ok(())
}
