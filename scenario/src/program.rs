//! Which program is a robot: `robots.program` for all of them, `[[robots.programs]]` for one
//! robot or a range of them (later entries win), the built-in `swarm-agent` otherwise.
//!
//! A robot program gets the arguments `swarm-agent` gets and the environment of
//! `swarmrt_protocol::services::env`; docs/robot-interface.md says what it must do.

use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::error::{ConfigError, KeyError};
use crate::limits::{MAX_ARG_BYTES, MAX_ARGS, MAX_PROGRAMS};

use crate::programs::COMMAND_LINE;
pub use crate::programs::{BUILTIN, ProgramFor, RobotIds, command_line};

/// `(key, command line)` of robot `id`'s program, `None` for the built-in robot. The key is
/// where the command line came from (`robots.program`, `robots.programs[2].program`).
pub fn program_of(cfg: &Config, id: u32) -> Option<(String, &[String])> {
    let r = &cfg.robots;
    let mut chosen: Option<(String, &[String])> =
        (!r.program.is_empty()).then(|| ("robots.program".to_string(), &r.program[..]));
    for (i, p) in r.programs.iter().enumerate() {
        if p.robots.range().is_ok_and(|ids| ids.contains(&id)) {
            chosen = Some((format!("robots.programs[{i}].program"), &p.program[..]));
        }
    }
    chosen.filter(|(_, argv)| argv[0] != BUILTIN)
}

/// True when any robot runs a program other than the built-in one.
pub fn any_foreign(cfg: &Config) -> bool {
    (0..cfg.robots.count).any(|id| program_of(cfg, id).is_some())
}

/// The shape checks (no file system): non-empty command lines of at most [`MAX_ARGS`] words
/// of at most [`MAX_ARG_BYTES`] bytes without a NUL (which no program can be given), at most
/// [`MAX_PROGRAMS`] entries, ranges inside `robots.count`.
pub fn validate(cfg: &Config) -> Result<(), KeyError> {
    let r = &cfg.robots;
    let nonempty = |key: &str, argv: &[String]| -> Result<(), KeyError> {
        if argv.first().is_none_or(|p| p.is_empty()) {
            return Err((key.to_string(), format!("expected {COMMAND_LINE}")));
        }
        if argv.len() > MAX_ARGS {
            return Err((
                key.to_string(),
                format!(
                    "expected {COMMAND_LINE}, of at most {MAX_ARGS} words, got {}",
                    argv.len()
                ),
            ));
        }
        for (i, word) in argv.iter().enumerate() {
            if word.len() > MAX_ARG_BYTES || word.contains('\0') {
                return Err((
                    format!("{key}[{i}]"),
                    format!(
                        "expected a word of at most {MAX_ARG_BYTES} bytes without a NUL \
                         character, got {} bytes{}",
                        word.len(),
                        if word.contains('\0') {
                            " with a NUL"
                        } else {
                            ""
                        }
                    ),
                ));
            }
        }
        Ok(())
    };
    if !r.program.is_empty() {
        nonempty("robots.program", &r.program)?;
    }
    if r.programs.len() > MAX_PROGRAMS {
        return Err((
            "robots.programs".to_string(),
            format!(
                "expected at most {MAX_PROGRAMS} entries, got {}",
                r.programs.len()
            ),
        ));
    }
    for (i, p) in r.programs.iter().enumerate() {
        nonempty(&format!("robots.programs[{i}].program"), &p.program)?;
        let key = format!("robots.programs[{i}].robots");
        let ids = p.robots.range().map_err(|m| (key.clone(), m))?;
        if ids.end > r.count {
            return Err((
                key,
                format!(
                    "robot ids {}..{} go past robots.count = {} (ids are 0..{})",
                    ids.start, ids.end, r.count, r.count
                ),
            ));
        }
    }
    Ok(())
}

/// Checks that every robot program can be started from `cwd`, and makes each command line's
/// program an absolute path (a path with a `/` is taken from `cwd`, a bare name from `PATH`),
/// so the resolved config starts the same programs wherever it is run from. `file` names the
/// config in errors.
pub fn resolve(cfg: &mut Config, file: &str, cwd: &Path) -> Result<(), ConfigError> {
    let fix = |key: String, argv: &mut Vec<String>| -> Result<(), ConfigError> {
        if argv.first().is_none_or(|p| p == BUILTIN) {
            return Ok(());
        }
        let key = format!("{key}[0]");
        match find_executable(&argv[0], cwd) {
            Ok(p) => {
                argv[0] = p.display().to_string();
                Ok(())
            }
            Err(why) => Err(ConfigError::new(file, key, why)),
        }
    };
    let r = &mut cfg.robots;
    fix("robots.program".into(), &mut r.program)?;
    for (i, p) in r.programs.iter_mut().enumerate() {
        fix(format!("robots.programs[{i}].program"), &mut p.program)?;
    }
    Ok(())
}

/// `program` as an executable file: a path with a `/` (relative to `cwd`), or a name on
/// `PATH`. The error says which it was not.
pub fn find_executable(program: &str, cwd: &Path) -> Result<PathBuf, String> {
    use std::os::unix::fs::PermissionsExt;
    let check = |p: &Path| -> Result<PathBuf, String> {
        let m = std::fs::metadata(p).map_err(|e| format!("cannot run {}: {e}", p.display()))?;
        if !m.is_file() {
            return Err(format!("cannot run {}: not a file", p.display()));
        }
        if m.permissions().mode() & 0o111 == 0 {
            return Err(format!(
                "cannot run {}: not executable (chmod +x it, or name an interpreter first, e.g. [\"python3\", \"{}\"])",
                p.display(),
                program
            ));
        }
        Ok(p.to_path_buf())
    };
    if program.contains('/') {
        return check(&cwd.join(program));
    }
    std::env::var_os("PATH")
        .and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join(program))
                .find(|p| check(p).is_ok())
        })
        .ok_or_else(|| {
            format!("cannot find the program {program:?} (not an executable file on PATH)")
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(extra: &str) -> Result<Config, ConfigError> {
        Config::from_toml_str(
            "t.toml",
            &format!(
                "[scenario]\nname = \"t\"\nticks = 5\n[map]\nbounds = [0.0, 0.0, 10.0, 10.0]\n\
                 goal = {{ x = 8.0, y = 2.0, radius = 1.0 }}\n[robots]\ncount = 6\n{extra}"
            ),
            &[],
        )
    }

    #[test]
    fn later_entries_win_and_swarm_agent_means_builtin() {
        let c = cfg(
            "program = [\"python3\", \"r.py\"]\n\
             programs = [{ robots = \"2..4\", program = [\"./c-robot\"] }, { robots = 3, program = [\"swarm-agent\"] }]",
        )
        .unwrap();
        assert_eq!(program_of(&c, 0).unwrap().1, ["python3", "r.py"]);
        assert_eq!(program_of(&c, 2).unwrap().0, "robots.programs[0].program");
        assert!(program_of(&c, 3).is_none());
        assert!(any_foreign(&c));
        assert!(!any_foreign(&cfg("").unwrap()));
    }

    #[test]
    fn bad_entries_name_their_key() {
        let e = cfg("programs = [{ robots = \"4..9\", program = [\"x\"] }]").unwrap_err();
        assert_eq!(e.key, "robots.programs[0].robots");
        let e = cfg("programs = [{ robots = 1, program = [] }]").unwrap_err();
        assert_eq!(e.key, "robots.programs[0].program");
        let e = cfg("program = []").unwrap_err();
        assert_eq!(e.key, "robots.program");
        assert!(e.message.contains("got []"), "{e}");
        let e = cfg("program = [\"x\", \"a\\u0000b\"]").unwrap_err();
        assert_eq!(e.key, "robots.program[1]");
        let e = cfg("programs = [{ robots = \"a..b\", program = [\"x\"] }]").unwrap_err();
        assert!(e.message.contains("range"), "{e}");
    }

    #[test]
    fn resolve_refuses_missing_and_non_executable_files() {
        let dir = std::env::temp_dir().join(format!("swarmrt-prog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("plain.py"), "print(1)").unwrap();
        let mut c = cfg("program = [\"./missing\"]").unwrap();
        let e = resolve(&mut c, "t.toml", &dir).unwrap_err();
        assert_eq!(e.key, "robots.program[0]");
        let mut c = cfg("programs = [{ robots = 0, program = [\"./plain.py\"] }]").unwrap();
        let e = resolve(&mut c, "t.toml", &dir).unwrap_err();
        assert_eq!(e.key, "robots.programs[0].program[0]");
        assert!(e.message.contains("not executable"), "{e}");
        let mut c = cfg("program = [\"sh\", \"x\"]").unwrap();
        resolve(&mut c, "t.toml", &dir).unwrap();
        assert!(c.robots.program[0].starts_with('/'));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
