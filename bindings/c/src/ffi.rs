//! The C API (`bindings/c/include/swarmrt.h`): thin `extern "C"` wrappers over [`Robot`],
//! [`Config`] and [`crate::frames`].
//!
//! Every function checks its pointers (a null one is an error, never a crash) and runs its
//! body under `catch_unwind`, so no panic crosses into C. [`C_API`] lists every function with
//! its Rust signature (checked by the compiler against the function itself); the C
//! declarations generated from it ([`c_declarations`]) are compiled together with
//! `swarmrt.h` by this crate's tests, so a header that drifts from the Rust functions fails
//! to compile there.

use std::ffi::{CStr, CString, c_char, c_int};
use std::os::unix::ffi::OsStrExt;
use std::panic::{AssertUnwindSafe, catch_unwind};

use swarmrt_protocol::{Command, Frame, Observation, PushError};

use crate::config::{Config, KeyError};
use crate::error::Error;
use crate::frames;
use crate::robot::{self, Robot, RobotEnv, Step};

/// `swarmrt_robot_t`: a robot and the text of its last error.
pub struct RobotHandle {
    robot: Robot,
    config_path: CString,
    storage_path: Option<CString>,
    run_id: CString,
    error: CString,
}

/// `swarmrt_config_t`.
pub type ConfigHandle = Config;

/// Success of a command helper.
pub const OK: c_int = 0;
/// The outbox already holds `MAX_OUTBOX` frames.
pub const ERR_OUTBOX_FULL: c_int = -1;
/// The payload does not fit a frame.
pub const ERR_TOO_LARGE: c_int = -2;
/// A required pointer was null.
pub const ERR_NULL: c_int = -3;
/// A panic inside the library (a bug): the call did nothing.
pub const ERR_PANIC: c_int = -4;

/// `swarmrt_robot_next`: an observation to answer.
pub const NEXT_OBSERVATION: c_int = 1;
/// `swarmrt_robot_next`: the world ended the run.
pub const NEXT_SHUTDOWN: c_int = 0;
/// `swarmrt_robot_next`: SIGTERM or SIGINT.
pub const NEXT_TERMINATED: c_int = -1;
/// `swarmrt_robot_next`: an error (`swarmrt_robot_error` says which).
pub const NEXT_ERROR: c_int = -2;

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Runs `f`, turning a panic into `Err(text)`.
fn guard<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f))
        .map_err(|p| format!("panic in libswarmrt: {}", panic_text(&*p)))
}

fn cstring(s: &str) -> CString {
    CString::new(s.replace('\0', "?")).expect("NULs replaced")
}

/// Writes `msg` into the caller's buffer, NUL-terminated, cut to fit (on a UTF-8 boundary).
///
/// # Safety
/// `buf` is null or points to `len` writable bytes.
unsafe fn write_err(buf: *mut c_char, len: usize, msg: &str) {
    if buf.is_null() || len == 0 {
        return;
    }
    let mut n = msg.len().min(len - 1);
    while !msg.is_char_boundary(n) {
        n -= 1;
    }
    // SAFETY: the caller's buffer holds `len` bytes; we write `n + 1 <= len`.
    unsafe {
        std::ptr::copy_nonoverlapping(msg.as_ptr(), buf.cast::<u8>(), n);
        *buf.add(n) = 0;
    }
}

/// The key as text, `None` when null or not UTF-8.
///
/// # Safety
/// `key` is null or a NUL-terminated string.
unsafe fn key_str<'a>(key: *const c_char) -> Option<&'a str> {
    if key.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated per the contract.
    unsafe { CStr::from_ptr(key) }.to_str().ok()
}

fn push_result(r: Result<(), PushError>) -> c_int {
    match r {
        Ok(()) => OK,
        Err(PushError::OutboxFull) => ERR_OUTBOX_FULL,
        Err(PushError::TooLarge) => ERR_TOO_LARGE,
    }
}

fn open(
    err: *mut c_char,
    err_len: usize,
    f: impl FnOnce() -> Result<RobotHandle, Error>,
) -> *mut RobotHandle {
    match guard(f) {
        Ok(Ok(h)) => Box::into_raw(Box::new(h)),
        Ok(Err(e)) => {
            // SAFETY: the caller's contract on `err`.
            unsafe { write_err(err, err_len, &e.to_string()) };
            std::ptr::null_mut()
        }
        Err(p) => {
            // SAFETY: as above.
            unsafe { write_err(err, err_len, &p) };
            std::ptr::null_mut()
        }
    }
}

/// Joins the run named by the environment (`SWARMRT_*`, set by `swarm run`): loads the
/// config, opens the node and the ports, says hello. `NULL` on failure, with the reason in
/// `err` (when not null).
///
/// # Safety
/// `err` is null or points to `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_open(err: *mut c_char, err_len: usize) -> *mut RobotHandle {
    open(err, err_len, || {
        let robot = Robot::open(RobotEnv::from_env()?)?;
        let env = robot.env();
        Ok(RobotHandle {
            config_path: cstring(&env.config.display().to_string()),
            storage_path: env
                .storage
                .as_ref()
                .map(|p| cstring(&p.display().to_string())),
            run_id: cstring(&env.run_id),
            error: CString::default(),
            robot,
        })
    })
}

/// Sleeps until there is an observation to answer: 1 with it copied into `out`, 0 when the
/// world ended the run, -1 after SIGTERM/SIGINT, -2 on an error.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`; `out` is null or points to an observation.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_next(
    robot: *mut RobotHandle,
    out: *mut Observation,
) -> c_int {
    // SAFETY: null or a live handle, used by one thread.
    let Some(h) = (unsafe { robot.as_mut() }) else {
        return NEXT_ERROR;
    };
    // SAFETY: null or a valid, writable observation.
    let Some(out) = (unsafe { out.as_mut() }) else {
        h.error = cstring("swarmrt_robot_next: out is NULL");
        return NEXT_ERROR;
    };
    let r = guard(|| h.robot.next(out));
    match r {
        Ok(Ok(Step::Observation)) => NEXT_OBSERVATION,
        Ok(Ok(Step::Shutdown)) => NEXT_SHUTDOWN,
        Ok(Ok(Step::Terminated)) => NEXT_TERMINATED,
        Ok(Err(e)) => {
            h.error = cstring(&e.to_string());
            NEXT_ERROR
        }
        Err(p) => {
            h.error = cstring(&p);
            NEXT_ERROR
        }
    }
}

/// Publishes `cmd` and wakes the world: 0, or -1 with the reason in `swarmrt_robot_error`
/// (-3 when a pointer is null).
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`; `cmd` is null or points to a command.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_send(robot: *mut RobotHandle, cmd: *const Command) -> c_int {
    // SAFETY: null or a live handle.
    let Some(h) = (unsafe { robot.as_mut() }) else {
        return ERR_NULL;
    };
    // SAFETY: null or a valid command.
    let Some(cmd) = (unsafe { cmd.as_ref() }) else {
        h.error = cstring("swarmrt_robot_send: cmd is NULL");
        return ERR_NULL;
    };
    match guard(|| h.robot.send(cmd)) {
        Ok(Ok(())) => OK,
        Ok(Err(e)) => {
            h.error = cstring(&e.to_string());
            -1
        }
        Err(p) => {
            h.error = cstring(&p);
            ERR_PANIC
        }
    }
}

/// The last error of `robot` ("" when none); valid until the next call on it.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_error(robot: *const RobotHandle) -> *const c_char {
    // SAFETY: null or a live handle.
    match unsafe { robot.as_ref() } {
        Some(h) => h.error.as_ptr(),
        None => c"robot is NULL".as_ptr(),
    }
}

/// This robot's id (`SWARMRT_ROBOT`); `UINT32_MAX` for a null robot.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_id(robot: *const RobotHandle) -> u32 {
    // SAFETY: null or a live handle.
    unsafe { robot.as_ref() }.map_or(u32::MAX, |h| h.robot.env().robot)
}

/// Scheduled restarts of this robot before this process (`SWARMRT_INCARNATION`).
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_incarnation(robot: *const RobotHandle) -> u32 {
    // SAFETY: null or a live handle.
    unsafe { robot.as_ref() }.map_or(0, |h| h.robot.env().incarnation)
}

/// The run id; `NULL` for a null robot.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_run_id(robot: *const RobotHandle) -> *const c_char {
    // SAFETY: null or a live handle.
    unsafe { robot.as_ref() }.map_or(std::ptr::null(), |h| h.run_id.as_ptr())
}

/// Path of the run's resolved config (`SWARMRT_CONFIG`); `NULL` for a null robot.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_config_path(robot: *const RobotHandle) -> *const c_char {
    // SAFETY: null or a live handle.
    unsafe { robot.as_ref() }.map_or(std::ptr::null(), |h| h.config_path.as_ptr())
}

/// The directory for state that must survive a scheduled restart (`SWARMRT_STORAGE`);
/// `NULL` when unset.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_storage_path(robot: *const RobotHandle) -> *const c_char {
    // SAFETY: null or a live handle.
    unsafe { robot.as_ref() }
        .and_then(|h| h.storage_path.as_ref())
        .map_or(std::ptr::null(), |p| p.as_ptr())
}

/// The run's resolved config, owned by `robot` (do not free it).
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_config(robot: *const RobotHandle) -> *const ConfigHandle {
    // SAFETY: null or a live handle.
    unsafe { robot.as_ref() }.map_or(std::ptr::null(), |h| h.robot.config())
}

/// Leaves the run: removes this robot's ports and node. Null is fine.
///
/// # Safety
/// `robot` is null or from `swarmrt_robot_open`, and not used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_close(robot: *mut RobotHandle) {
    if robot.is_null() {
        return;
    }
    // SAFETY: from Box::into_raw in `swarmrt_robot_open`, closed once.
    let h = unsafe { Box::from_raw(robot) };
    // A panic while dropping iceoryx2 ports must not unwind into C; the process is leaving.
    let _ = guard(move || drop(h));
}

/// The process exit code for how `swarmrt_robot_next` ended: 0 for 0 (shutdown), 143 for -1
/// (SIGTERM/SIGINT), 1 otherwise.
#[unsafe(no_mangle)]
pub extern "C" fn swarmrt_exit_code(next_result: c_int) -> c_int {
    match next_result {
        NEXT_SHUTDOWN => robot::exit_code(Ok(Step::Shutdown)),
        NEXT_TERMINATED => robot::exit_code(Ok(Step::Terminated)),
        _ => robot::EXIT_FAILED,
    }
}

/// Reads and parses the TOML file at `path`; `NULL` with the reason in `err` on failure.
/// Free it with `swarmrt_config_free`.
///
/// # Safety
/// `path` is null or NUL-terminated; `err` is null or points to `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_load(
    path: *const c_char,
    err: *mut c_char,
    err_len: usize,
) -> *mut ConfigHandle {
    // SAFETY: null or NUL-terminated.
    let path = (!path.is_null()).then(|| unsafe { CStr::from_ptr(path) }.to_bytes().to_vec());
    config_handle(err, err_len, move || {
        let path = path.ok_or_else(|| Error::Config {
            path: "NULL".into(),
            message: "no path given".into(),
        })?;
        Config::load(std::path::Path::new(std::ffi::OsStr::from_bytes(&path)))
    })
}

/// Parses TOML text; `NULL` with the reason in `err` on failure. Free it with
/// `swarmrt_config_free`.
///
/// # Safety
/// `text` is null or NUL-terminated; `err` is null or points to `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_parse(
    text: *const c_char,
    err: *mut c_char,
    err_len: usize,
) -> *mut ConfigHandle {
    // SAFETY: null or NUL-terminated.
    let text = (!text.is_null()).then(|| {
        unsafe { CStr::from_ptr(text) }
            .to_string_lossy()
            .into_owned()
    });
    config_handle(err, err_len, move || {
        Config::parse(&text.ok_or_else(|| Error::Config {
            path: "<text>".into(),
            message: "text is NULL".into(),
        })?)
    })
}

fn config_handle(
    err: *mut c_char,
    err_len: usize,
    f: impl FnOnce() -> Result<Config, Error>,
) -> *mut ConfigHandle {
    let msg = match guard(f) {
        Ok(Ok(c)) => return Box::into_raw(Box::new(c)),
        Ok(Err(e)) => e.to_string(),
        Err(p) => p,
    };
    // SAFETY: the caller's contract on `err`.
    unsafe { write_err(err, err_len, &msg) };
    std::ptr::null_mut()
}

/// Frees a config from `swarmrt_config_load`/`swarmrt_config_parse` (not a robot's). Null is
/// fine.
///
/// # Safety
/// `cfg` is null or from `swarmrt_config_load`/`swarmrt_config_parse`, freed once.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_free(cfg: *mut ConfigHandle) {
    if !cfg.is_null() {
        // SAFETY: from Box::into_raw, freed once.
        let c = unsafe { Box::from_raw(cfg) };
        let _ = guard(move || drop(c));
    }
}

/// Shared body of the typed getters: 1 found (written to `out`), 0 absent, -1 wrong type,
/// malformed key or a null pointer.
///
/// # Safety
/// `cfg` is null or a live config; `key` null or NUL-terminated; `out` null or writable.
unsafe fn get<T>(
    cfg: *const ConfigHandle,
    key: *const c_char,
    out: *mut T,
    read: impl FnOnce(&Config, &str) -> Result<Option<T>, KeyError>,
) -> c_int {
    // SAFETY: the caller's contract.
    let (Some(cfg), Some(key), false) = (
        unsafe { cfg.as_ref() },
        unsafe { key_str(key) },
        out.is_null(),
    ) else {
        return -1;
    };
    match guard(|| read(cfg, key)) {
        Ok(Ok(Some(v))) => {
            // SAFETY: non-null and writable per the contract.
            unsafe { out.write(v) };
            1
        }
        Ok(Ok(None)) => 0,
        Ok(Err(_)) | Err(_) => -1,
    }
}

/// The number at `key` (`"map.goal.x"`, `"map.bounds[2]"`; integers are converted): 1 found,
/// 0 absent, -1 not a number, a malformed key or a null pointer.
///
/// # Safety
/// `cfg` is null or a live config; `key` null or NUL-terminated; `out` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_f64(
    cfg: *const ConfigHandle,
    key: *const c_char,
    out: *mut f64,
) -> c_int {
    // SAFETY: forwarded contract.
    unsafe { get(cfg, key, out, |c, k| c.f64(k)) }
}

/// The integer at `key`: 1 found, 0 absent, -1 not an integer, a malformed key or a null
/// pointer.
///
/// # Safety
/// `cfg` is null or a live config; `key` null or NUL-terminated; `out` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_i64(
    cfg: *const ConfigHandle,
    key: *const c_char,
    out: *mut i64,
) -> c_int {
    // SAFETY: forwarded contract.
    unsafe { get(cfg, key, out, |c, k| c.i64(k)) }
}

/// The length of the array (or table) at `key`: 1 found, 0 absent, -1 neither, a malformed
/// key or a null pointer.
///
/// # Safety
/// `cfg` is null or a live config; `key` null or NUL-terminated; `out` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_len(
    cfg: *const ConfigHandle,
    key: *const c_char,
    out: *mut usize,
) -> c_int {
    // SAFETY: forwarded contract.
    unsafe { get(cfg, key, out, |c, k| c.len(k)) }
}

/// The string at `key`, NUL-terminated into `buf`: 1 found, 0 absent, -1 not a string, too
/// long for `buf_len` (`buf` then holds ""), a malformed key or a null pointer.
///
/// # Safety
/// `cfg` is null or a live config; `key` null or NUL-terminated; `buf` null or `buf_len`
/// writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_config_str(
    cfg: *const ConfigHandle,
    key: *const c_char,
    buf: *mut c_char,
    buf_len: usize,
) -> c_int {
    if buf.is_null() || buf_len == 0 {
        return -1;
    }
    // SAFETY: `buf` holds at least one byte.
    unsafe { *buf = 0 };
    // SAFETY: the caller's contract.
    let (Some(cfg), Some(key)) = (unsafe { cfg.as_ref() }, unsafe { key_str(key) }) else {
        return -1;
    };
    match guard(|| cfg.str(key).map(|s| s.map(str::to_owned))) {
        Ok(Ok(Some(s))) if s.len() < buf_len && !s.contains('\0') => {
            // SAFETY: `buf` holds `buf_len > s.len()` bytes.
            unsafe { write_err(buf, buf_len, &s) };
            1
        }
        Ok(Ok(None)) => 0,
        Ok(Ok(Some(_))) | Ok(Err(_)) | Err(_) => -1,
    }
}

/// Fills `out` with a stopped, silent `KIND_ACT` command answering `obs` (its robot and
/// tick): set `v`, `omega`, `lidar_on`, frames, then send it. Does nothing when a pointer is
/// null.
///
/// # Safety
/// `obs` is null or points to an observation; `out` null or to a writable command.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_robot_act(obs: *const Observation, out: *mut Command) {
    // SAFETY: the caller's contract.
    if let (Some(obs), false) = (unsafe { obs.as_ref() }, out.is_null()) {
        // SAFETY: non-null and writable.
        unsafe { out.write(Command::act(obs.robot, obs.tick)) };
    }
}

/// Queues an opaque frame (first payload byte `SWARMRT_OPAQUE_TAG`, then `len <
/// SWARMRT_MAX_PAYLOAD` raw bytes) for `dst` or `SWARMRT_BROADCAST`: 0, or
/// `SWARMRT_ERR_OUTBOX_FULL`, `SWARMRT_ERR_TOO_LARGE`, `SWARMRT_ERR_NULL`. Rust robots skip
/// opaque frames; robots of one kind use them to talk.
///
/// # Safety
/// `cmd` is null or a writable command; `bytes` null (with `len` 0) or `len` readable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_command_push_opaque(
    cmd: *mut Command,
    dst: u32,
    bytes: *const u8,
    len: usize,
) -> c_int {
    // SAFETY: the caller's contract.
    let Some(cmd) = (unsafe { cmd.as_mut() }) else {
        return ERR_NULL;
    };
    let bytes: &[u8] = match (bytes.is_null(), len) {
        (_, 0) => &[],
        (true, _) => return ERR_NULL,
        // SAFETY: `len` readable bytes per the contract.
        (false, n) => unsafe { std::slice::from_raw_parts(bytes, n) },
    };
    guard(|| push_result(frames::push_opaque(cmd, dst, bytes))).unwrap_or(ERR_PANIC)
}

/// Queues the go-to behaviour's pose beacon for `dst` or `SWARMRT_BROADCAST`, the bytes the
/// Rust go-to robot sends: 0, or `SWARMRT_ERR_OUTBOX_FULL`, `SWARMRT_ERR_NULL`.
///
/// # Safety
/// `cmd` is null or a writable command.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_command_push_goto_beacon(
    cmd: *mut Command,
    dst: u32,
    x: f64,
    y: f64,
    theta: f64,
) -> c_int {
    // SAFETY: the caller's contract.
    let Some(cmd) = (unsafe { cmd.as_mut() }) else {
        return ERR_NULL;
    };
    guard(|| push_result(frames::push_goto_beacon(cmd, dst, x, y, theta))).unwrap_or(ERR_PANIC)
}

/// 1 when `frame` is opaque, with `*bytes` pointing into it and `*len` its raw bytes; 0
/// otherwise (and for null pointers).
///
/// # Safety
/// `frame` null or a frame that outlives the use of `*bytes`; `bytes`, `len` null or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_frame_opaque(
    frame: *const Frame,
    bytes: *mut *const u8,
    len: *mut usize,
) -> c_int {
    // SAFETY: the caller's contract.
    let Some(frame) = (unsafe { frame.as_ref() }) else {
        return 0;
    };
    if bytes.is_null() || len.is_null() {
        return 0;
    }
    match frame.opaque_bytes() {
        Some(b) => {
            // SAFETY: non-null and writable.
            unsafe {
                bytes.write(b.as_ptr());
                len.write(b.len());
            }
            1
        }
        None => 0,
    }
}

/// 1 when `frame` is a go-to beacon, with its pose in `*x`, `*y`, `*theta`; 0 otherwise
/// (and for null pointers).
///
/// # Safety
/// `frame` null or a frame; `x`, `y`, `theta` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swarmrt_frame_goto_beacon(
    frame: *const Frame,
    x: *mut f64,
    y: *mut f64,
    theta: *mut f64,
) -> c_int {
    // SAFETY: the caller's contract.
    let Some(frame) = (unsafe { frame.as_ref() }) else {
        return 0;
    };
    if x.is_null() || y.is_null() || theta.is_null() {
        return 0;
    }
    match frames::goto_beacon(frame) {
        Some((bx, by, bt)) => {
            // SAFETY: non-null and writable.
            unsafe {
                x.write(bx);
                y.write(by);
                theta.write(bt);
            }
            1
        }
        None => 0,
    }
}

/// One exported function: its name and its Rust parameter and return types as written.
#[derive(Debug, Clone, Copy)]
pub struct Signature {
    /// The C name.
    pub name: &'static str,
    /// Parameter types, as Rust spells them.
    pub args: &'static [&'static str],
    /// The return type, as Rust spells it (`()` for none).
    pub ret: &'static str,
}

/// Lists the exported functions; each line is checked against the function by the compiler.
macro_rules! c_api {
    ($($name:ident: fn($($arg:ty),*) $(-> $ret:ty)?;)+) => {
        $(const _: unsafe extern "C" fn($($arg),*) $(-> $ret)? = $name;)+
        /// Every function of the C API with its Rust signature.
        pub const C_API: &[Signature] = &[$(Signature {
            name: stringify!($name),
            args: &[$(stringify!($arg)),*],
            ret: c_api!(@ret $($ret)?),
        }),+];
    };
    (@ret) => { "()" };
    (@ret $r:ty) => { stringify!($r) };
}

c_api! {
    swarmrt_robot_open: fn(*mut c_char, usize) -> *mut RobotHandle;
    swarmrt_robot_next: fn(*mut RobotHandle, *mut Observation) -> c_int;
    swarmrt_robot_send: fn(*mut RobotHandle, *const Command) -> c_int;
    swarmrt_robot_error: fn(*const RobotHandle) -> *const c_char;
    swarmrt_robot_id: fn(*const RobotHandle) -> u32;
    swarmrt_robot_incarnation: fn(*const RobotHandle) -> u32;
    swarmrt_robot_run_id: fn(*const RobotHandle) -> *const c_char;
    swarmrt_robot_config_path: fn(*const RobotHandle) -> *const c_char;
    swarmrt_robot_storage_path: fn(*const RobotHandle) -> *const c_char;
    swarmrt_robot_config: fn(*const RobotHandle) -> *const ConfigHandle;
    swarmrt_robot_close: fn(*mut RobotHandle);
    swarmrt_exit_code: fn(c_int) -> c_int;
    swarmrt_config_load: fn(*const c_char, *mut c_char, usize) -> *mut ConfigHandle;
    swarmrt_config_parse: fn(*const c_char, *mut c_char, usize) -> *mut ConfigHandle;
    swarmrt_config_free: fn(*mut ConfigHandle);
    swarmrt_config_f64: fn(*const ConfigHandle, *const c_char, *mut f64) -> c_int;
    swarmrt_config_i64: fn(*const ConfigHandle, *const c_char, *mut i64) -> c_int;
    swarmrt_config_len: fn(*const ConfigHandle, *const c_char, *mut usize) -> c_int;
    swarmrt_config_str: fn(*const ConfigHandle, *const c_char, *mut c_char, usize) -> c_int;
    swarmrt_robot_act: fn(*const Observation, *mut Command);
    swarmrt_command_push_opaque: fn(*mut Command, u32, *const u8, usize) -> c_int;
    swarmrt_command_push_goto_beacon: fn(*mut Command, u32, f64, f64, f64) -> c_int;
    swarmrt_frame_opaque: fn(*const Frame, *mut *const u8, *mut usize) -> c_int;
    swarmrt_frame_goto_beacon: fn(*const Frame, *mut f64, *mut f64, *mut f64) -> c_int;
}

/// The C spelling of a Rust parameter or return type of [`C_API`].
pub fn c_type(rust: &str) -> Option<&'static str> {
    let t: String = rust.chars().filter(|c| !c.is_whitespace()).collect();
    Some(match t.as_str() {
        "()" => "void",
        "c_int" => "int",
        "u32" => "uint32_t",
        "usize" => "size_t",
        "f64" => "double",
        "*mutc_char" => "char *",
        "*constc_char" => "const char *",
        "*mutusize" => "size_t *",
        "*mutf64" => "double *",
        "*muti64" => "int64_t *",
        "*constu8" => "const uint8_t *",
        "*mut*constu8" => "const uint8_t **",
        "*mutRobotHandle" => "swarmrt_robot_t *",
        "*constRobotHandle" => "const swarmrt_robot_t *",
        "*mutConfigHandle" => "swarmrt_config_t *",
        "*constConfigHandle" => "const swarmrt_config_t *",
        "*mutObservation" => "swarmrt_observation_t *",
        "*constObservation" => "const swarmrt_observation_t *",
        "*mutCommand" => "swarmrt_command_t *",
        "*constCommand" => "const swarmrt_command_t *",
        "*constFrame" => "const swarmrt_frame_t *",
        _ => return None,
    })
}

/// C declarations of every function of [`C_API`], from the Rust signatures. Compiled after
/// `swarmrt.h`, a C compiler rejects any function whose header declaration differs.
pub fn c_declarations() -> String {
    let mut out = String::from("/* Generated from swarmrt::ffi::C_API by the tests. */\n");
    for s in C_API {
        let ty = |t: &str| c_type(t).unwrap_or_else(|| panic!("{}: no C type for `{t}`", s.name));
        let args: Vec<&str> = s.args.iter().map(|a| ty(a)).collect();
        let args = if args.is_empty() {
            "void".to_string()
        } else {
            args.join(", ")
        };
        let ret = ty(s.ret);
        let gap = if ret.ends_with('*') { "" } else { " " };
        out.push_str(&format!("{ret}{gap}{}({args});\n", s.name));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_signature_has_a_c_spelling() {
        let decls = c_declarations();
        assert_eq!(decls.lines().count(), C_API.len() + 1);
        assert!(
            decls.contains("swarmrt_robot_t *swarmrt_robot_open(char *, size_t);"),
            "{decls}"
        );
    }

    #[test]
    fn null_pointers_are_errors_not_crashes() {
        unsafe {
            assert_eq!(
                swarmrt_robot_next(std::ptr::null_mut(), std::ptr::null_mut()),
                NEXT_ERROR
            );
            assert_eq!(
                swarmrt_robot_send(std::ptr::null_mut(), std::ptr::null()),
                ERR_NULL
            );
            assert_eq!(swarmrt_robot_id(std::ptr::null()), u32::MAX);
            assert!(swarmrt_robot_config(std::ptr::null()).is_null());
            swarmrt_robot_close(std::ptr::null_mut());
            swarmrt_config_free(std::ptr::null_mut());
            assert_eq!(
                swarmrt_config_f64(std::ptr::null(), c"x".as_ptr(), &mut 0.0),
                -1
            );
            assert_eq!(
                swarmrt_command_push_opaque(std::ptr::null_mut(), 0, std::ptr::null(), 0),
                ERR_NULL
            );
            let mut cmd = Command::act(0, 0);
            assert_eq!(
                swarmrt_command_push_opaque(&mut cmd, 0, std::ptr::null(), 3),
                ERR_NULL
            );
            assert_eq!(
                swarmrt_command_push_opaque(&mut cmd, 0, std::ptr::null(), 0),
                OK
            );
            assert_eq!(
                swarmrt_frame_goto_beacon(std::ptr::null(), &mut 0.0, &mut 0.0, &mut 0.0),
                0
            );
            let mut err = [0 as c_char; 8];
            assert!(swarmrt_config_load(std::ptr::null(), err.as_mut_ptr(), err.len()).is_null());
            assert_eq!(CStr::from_ptr(err.as_ptr()).to_str().unwrap(), "config ");
        }
    }

    #[test]
    fn strings_are_copied_whole_or_not_at_all() {
        unsafe {
            let cfg = swarmrt_config_parse(
                c"[behaviour]\nkind = \"goto\"\n".as_ptr(),
                std::ptr::null_mut(),
                0,
            );
            assert!(!cfg.is_null());
            let mut buf = [1 as c_char; 5];
            assert_eq!(
                swarmrt_config_str(cfg, c"behaviour.kind".as_ptr(), buf.as_mut_ptr(), 5),
                1
            );
            assert_eq!(CStr::from_ptr(buf.as_ptr()).to_str().unwrap(), "goto");
            assert_eq!(
                swarmrt_config_str(cfg, c"behaviour.kind".as_ptr(), buf.as_mut_ptr(), 4),
                -1
            );
            assert_eq!(buf[0], 0);
            assert_eq!(
                swarmrt_config_str(cfg, c"behaviour.speed".as_ptr(), buf.as_mut_ptr(), 5),
                0
            );
            assert_eq!(
                swarmrt_config_str(cfg, c"behaviour".as_ptr(), buf.as_mut_ptr(), 5),
                -1
            );
            swarmrt_config_free(cfg);
        }
    }

    #[test]
    fn an_error_is_cut_to_the_buffer_on_a_character_boundary() {
        let mut buf = [0x55 as c_char; 4];
        unsafe { write_err(buf.as_mut_ptr(), 4, "aé€") };
        assert_eq!(
            unsafe { CStr::from_ptr(buf.as_ptr()) }.to_str().unwrap(),
            "aé"
        );
        unsafe { write_err(buf.as_mut_ptr(), 1, "abc") };
        assert_eq!(buf[0], 0);
    }
}
