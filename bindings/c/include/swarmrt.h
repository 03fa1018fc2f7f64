/* swarmrt: a robot controller in C joins a swarmrt run.
 *
 * Link with libswarmrt.a (`cargo build --release -p swarmrt-c` writes
 * target/release/libswarmrt.a) and the C libraries Rust's standard library needs:
 *
 *   cc -std=c11 -O2 -I bindings/c/include robot.c target/release/libswarmrt.a \
 *      -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc -o robot
 *
 * and start it as a robot program:
 *
 *   swarm run cfg.toml --set 'robots.program=["/abs/path/robot"]'
 *   # or for some robots: [[robots.programs]] robots = "0..3"  program = ["/abs/path/robot"]
 *
 * The program gets swarm-agent's arguments appended (--run-id --robot --incarnation --config
 * --storage) and the run's names in SWARMRT_* variables; swarmrt_robot_open reads the
 * variables, so a program may ignore its arguments. A robot:
 *
 *   char err[256];
 *   swarmrt_robot_t *r = swarmrt_robot_open(err, sizeof err);   // env, node, ports, hello
 *   if (!r) { fprintf(stderr, "%s\n", err); return SWARMRT_EXIT_FAILED; }
 *   swarmrt_observation_t obs;
 *   swarmrt_command_t cmd;
 *   int rc;
 *   while ((rc = swarmrt_robot_next(r, &obs)) == SWARMRT_NEXT_OBSERVATION) {
 *       swarmrt_robot_act(&obs, &cmd);    // KIND_ACT for obs.tick: stopped, silent, lidar off
 *       if (obs.state == SWARMRT_STATE_ACTIVE) { cmd.v = 0.3; cmd.lidar_on = 1; }
 *       if (swarmrt_robot_send(r, &cmd) != 0) { rc = SWARMRT_NEXT_ERROR; break; }
 *   }
 *   if (rc == SWARMRT_NEXT_ERROR) fprintf(stderr, "%s\n", swarmrt_robot_error(r));
 *   swarmrt_robot_close(r);              // removes this robot's ports and node
 *   return swarmrt_exit_code(rc);        // 0 only when the world ended the run; 143 SIGTERM
 *
 * What the library does for you, as the Rust robot does (runtime/src/robot/shell.rs): it drains every
 * queued sample per wake-up, checks the protocol version, reads this robot's slot
 * (robot - SWARMRT_SLOT_OFFSET), returns only ticks to answer (state ACTIVE or DOWN: a DOWN
 * robot answers and the world ignores the command), treats an interrupted wait (EINTR after
 * the SIGCONT that ends a scheduled freeze) as a spurious wake, and ends only on the world's
 * shutdown sample (0) or iceoryx2's termination request after SIGTERM/SIGINT (-1). Answer
 * every observation `next` returns with exactly one `send`: the world waits for it.
 *
 * Threads: one thread drives a robot. Errors: no function aborts or unwinds into C; a null
 * pointer is an error. Strings returned stay valid until swarmrt_robot_close. */
#ifndef SWARMRT_H
#define SWARMRT_H

#include <stddef.h>
#include <stdint.h>

#include "swarmrt_messages.h"
#include "swarmrt_tags.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A robot joined to a run (opaque). */
typedef struct swarmrt_robot swarmrt_robot_t;
/* A parsed TOML config (opaque). */
typedef struct swarmrt_config swarmrt_config_t;

/* swarmrt_robot_next results. */
#define SWARMRT_NEXT_OBSERVATION 1 /* an observation to answer, copied into *out */
#define SWARMRT_NEXT_SHUTDOWN 0    /* the world ended the run: exit 0 */
#define SWARMRT_NEXT_TERMINATED (-1) /* SIGTERM or SIGINT: exit 143 */
#define SWARMRT_NEXT_ERROR (-2)    /* see swarmrt_robot_error: exit 1 */

/* Exit codes the orchestrator reads: 0 means exactly "the world sent shutdown". */
#define SWARMRT_EXIT_SHUTDOWN 0
#define SWARMRT_EXIT_FAILED 1
#define SWARMRT_EXIT_TERMINATED 143

/* Results of the command helpers. */
#define SWARMRT_OK 0
#define SWARMRT_ERR_OUTBOX_FULL (-1) /* the outbox already holds SWARMRT_MAX_OUTBOX frames */
#define SWARMRT_ERR_TOO_LARGE (-2)   /* the payload does not fit one frame */
#define SWARMRT_ERR_NULL (-3)        /* a required pointer was NULL */
#define SWARMRT_ERR_PANIC (-4)       /* a bug inside the library; nothing was done */

/* ---- The robot ---------------------------------------------------------------------- */

/* Joins the run named by the environment (SWARMRT_RUN_ID, SWARMRT_ROBOT, SWARMRT_CONFIG, ...):
 * loads the resolved config, creates the node and the ports, says hello. NULL on failure with
 * the reason written NUL-terminated into err (when err is not NULL). */
swarmrt_robot_t *swarmrt_robot_open(char *err, size_t err_len);

/* Sleeps until there is an observation to answer. Returns SWARMRT_NEXT_OBSERVATION with it
 * copied into *out, SWARMRT_NEXT_SHUTDOWN, SWARMRT_NEXT_TERMINATED or SWARMRT_NEXT_ERROR.
 * After the run has ended it returns the same end again at once. */
int swarmrt_robot_next(swarmrt_robot_t *robot, swarmrt_observation_t *out);

/* Publishes *cmd and wakes the world. 0; -1 with the reason in swarmrt_robot_error;
 * SWARMRT_ERR_NULL; SWARMRT_ERR_PANIC. */
int swarmrt_robot_send(swarmrt_robot_t *robot, const swarmrt_command_t *cmd);

/* The last error of robot ("" when none). */
const char *swarmrt_robot_error(const swarmrt_robot_t *robot);

/* This robot's id (SWARMRT_ROBOT); UINT32_MAX for NULL. */
uint32_t swarmrt_robot_id(const swarmrt_robot_t *robot);

/* Scheduled restarts of this robot before this process (SWARMRT_INCARNATION). */
uint32_t swarmrt_robot_incarnation(const swarmrt_robot_t *robot);

/* The run id (lower-case hex). */
const char *swarmrt_robot_run_id(const swarmrt_robot_t *robot);

/* Path of the run's resolved config (SWARMRT_CONFIG), every key the run uses present. */
const char *swarmrt_robot_config_path(const swarmrt_robot_t *robot);

/* A directory for state that must survive a scheduled restart (SWARMRT_STORAGE); NULL when
 * unset. */
const char *swarmrt_robot_storage_path(const swarmrt_robot_t *robot);

/* The run's resolved config, owned by robot (do not free it). */
const swarmrt_config_t *swarmrt_robot_config(const swarmrt_robot_t *robot);

/* Leaves the run: removes this robot's ports and node, frees robot. NULL is fine. */
void swarmrt_robot_close(swarmrt_robot_t *robot);

/* The exit code for a swarmrt_robot_next result: 0 for SHUTDOWN, 143 for TERMINATED, 1
 * otherwise. */
int swarmrt_exit_code(int next_result);

/* ---- Messages ----------------------------------------------------------------------- */

/* Fills *out with a stopped, silent SWARMRT_KIND_ACT command answering *obs (its robot and
 * tick, v = omega = 0, lidar off, no frames, no report). */
void swarmrt_robot_act(const swarmrt_observation_t *obs, swarmrt_command_t *out);

/* Queues an opaque frame for dst (a robot id or SWARMRT_BROADCAST): payload byte 0 is
 * SWARMRT_OPAQUE_TAG, then len < SWARMRT_MAX_PAYLOAD raw bytes. Rust robots skip opaque
 * frames; robots of one kind use them to talk. SWARMRT_OK, SWARMRT_ERR_OUTBOX_FULL,
 * SWARMRT_ERR_TOO_LARGE or SWARMRT_ERR_NULL. */
int swarmrt_command_push_opaque(swarmrt_command_t *cmd, uint32_t dst, const uint8_t *bytes,
                                size_t len);

/* Queues the go-to behaviour's pose beacon for dst: the bytes the Rust go-to robot sends
 * (postcard RadioMsg::Goto(Beacon { x, y, theta }): byte SWARMRT_TAG_GOTO, then x, y,
 * theta as little-endian doubles). SWARMRT_OK, SWARMRT_ERR_OUTBOX_FULL or SWARMRT_ERR_NULL. */
int swarmrt_command_push_goto_beacon(swarmrt_command_t *cmd, uint32_t dst, double x, double y,
                                     double theta);

/* 1 when *frame is opaque, with *bytes pointing into the frame and *len its raw bytes (after
 * the tag); 0 otherwise. */
int swarmrt_frame_opaque(const swarmrt_frame_t *frame, const uint8_t **bytes, size_t *len);

/* 1 when *frame is a go-to beacon, with the sender's pose in *x, *y, *theta; 0 otherwise. */
int swarmrt_frame_goto_beacon(const swarmrt_frame_t *frame, double *x, double *y,
                              double *theta);

/* ---- Config ------------------------------------------------------------------------- */
/* Keys are dotted paths with array indices as numbers or in brackets: "map.goal.x",
 * "map.bounds.2", "map.bounds[2]", "robots.start.groups[0].goal[1]". Optional keys that are
 * unset are absent from the resolved config (e.g. robots.lidar.angles_deg). Getters return
 * 1 found (written to *out), 0 absent, -1 another type, a malformed key or a NULL pointer. */

/* Reads and parses the TOML file at path; NULL with the reason in err. Free with
 * swarmrt_config_free. */
swarmrt_config_t *swarmrt_config_load(const char *path, char *err, size_t err_len);

/* Parses TOML text; NULL with the reason in err. Free with swarmrt_config_free. */
swarmrt_config_t *swarmrt_config_parse(const char *text, char *err, size_t err_len);

/* Frees a config from swarmrt_config_load/_parse (never a robot's). NULL is fine. */
void swarmrt_config_free(swarmrt_config_t *cfg);

/* A number (integers are converted), as the Rust robot reads it: the same bits. */
int swarmrt_config_f64(const swarmrt_config_t *cfg, const char *key, double *out);

/* An integer (a float, even a whole one, is another type). */
int swarmrt_config_i64(const swarmrt_config_t *cfg, const char *key, int64_t *out);

/* The number of elements of an array, or of keys of a table. */
int swarmrt_config_len(const swarmrt_config_t *cfg, const char *key, size_t *out);

/* A string, NUL-terminated into buf; -1 (buf = "") when it needs more than buf_len bytes. */
int swarmrt_config_str(const swarmrt_config_t *cfg, const char *key, char *buf,
                       size_t buf_len);

#ifdef __cplusplus
}
#endif

#endif /* SWARMRT_H */
