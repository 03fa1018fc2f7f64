//! The end-to-end tests: real processes, real iceoryx2, run directories checked. One file per
//! topic, all in one test binary so that it links once and its tests share the cores (they
//! ran as 35 binaries one after another, each linking the same graph: issue 49).
//!
//! One topic: `cargo test -p swarmrt-tests --test e2e crashes::`. The viewer's browser tests
//! are their own binary (`--test viewer`).
//!
//! Every test must stand beside any other: a run owns its run id, its directory and its
//! iceoryx2 root; checks for leftovers look at that run id only; shared installs (apt, the
//! Python venv, the C library, the Slurm lab) are made once under a lock.

mod bad_input;
mod bad_robots;
mod bell;
mod bench;
mod build_graph;
mod c_robots;
mod chain;
mod chaos;
mod config_fuzz;
mod consensus;
mod crashes;
mod determinism;
mod export_mcap;
mod faults;
mod flocking;
mod formation;
mod grouping;
mod local_users;
mod multihost;
mod planner;
mod python_package;
mod python_robots;
mod radio_record;
mod records_pinned;
mod refuse_files;
mod robot_interface;
mod run;
mod run_dir;
mod scale;
mod shm_root;
mod slurm;
mod sweep;
mod sweep_ssh;
mod tune;
mod viewer_attacks;

/// Test threads when `RUST_TEST_THREADS` is not set: four per core, at most 16. The tests
/// mostly wait on the processes they start (at libtest's one thread per core the binary used
/// 1.2 of 2 cores), so more of them at once fill the machine: on 2 cores, 247 s at 2 threads,
/// 173 s at 4, 157 s at 8 (docs/benchmarks.md, "The test suite"). `--test-threads` still wins.
fn default_test_threads() {
    if std::env::var_os("RUST_TEST_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = (4 * cores).min(16);
    // SAFETY: runs from `.init_array` before `main`, when this process has one thread.
    unsafe { std::env::set_var("RUST_TEST_THREADS", threads.to_string()) };
}

/// Runs [`default_test_threads`] before libtest's `main` reads the variable.
#[used]
#[unsafe(link_section = ".init_array")]
static DEFAULT_TEST_THREADS: extern "C" fn() = {
    extern "C" fn init() {
        default_test_threads();
    }
    init
};
