/* The C API from C: compiled against swarmrt.h together with declarations generated from
 * the Rust functions (swarmrt_decls.h, by tests/c_api.rs), so a header that drifts from
 * the library fails to compile; linked with libswarmrt.a and run, so every function is
 * there and does what the header says. Prints "ok" and exits 0, or names the first failed
 * check and exits 1. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swarmrt.h"
#include "swarmrt_decls.h"

#define CHECK(cond)                                                             \
    do {                                                                        \
        if (!(cond)) {                                                          \
            fprintf(stderr, "c_api.c:%d: check failed: %s\n", __LINE__, #cond); \
            return 1;                                                           \
        }                                                                       \
    } while (0)

static const char *TOML =
    "[map]\n"
    "bounds = [0.0, 0.0, 12.0, 12.5]\n"
    "[map.goal]\n"
    "x = 10.0\n"
    "y = 10\n"
    "[robots]\n"
    "count = 9\n"
    "[robots.start]\n"
    "groups = [{ x = 1.0, y = 2.0, goal = [3.0, 4.0] }]\n"
    "[behaviour]\n"
    "kind = \"goto\"\n";

static int config(void) {
    char err[128] = "";
    swarmrt_config_t *cfg = swarmrt_config_parse(TOML, err, sizeof err);
    CHECK(cfg != NULL);
    double d = 0.0;
    int64_t i = 0;
    size_t n = 0;
    char s[8];
    CHECK(swarmrt_config_f64(cfg, "map.goal.x", &d) == 1 && d == 10.0);
    CHECK(swarmrt_config_f64(cfg, "map.goal.y", &d) == 1 && d == 10.0);
    CHECK(swarmrt_config_f64(cfg, "map.bounds[3]", &d) == 1 && d == 12.5);
    CHECK(swarmrt_config_f64(cfg, "map.bounds.3", &d) == 1 && d == 12.5);
    CHECK(swarmrt_config_f64(cfg, "robots.start.groups[0].goal[1]", &d) == 1 && d == 4.0);
    CHECK(swarmrt_config_f64(cfg, "robots.lidar.angles_deg[0]", &d) == 0);
    CHECK(swarmrt_config_f64(cfg, "behaviour.kind", &d) == -1);
    CHECK(swarmrt_config_f64(cfg, "map..goal", &d) == -1);
    CHECK(swarmrt_config_f64(cfg, "map.goal.x", NULL) == -1);
    CHECK(swarmrt_config_i64(cfg, "robots.count", &i) == 1 && i == 9);
    CHECK(swarmrt_config_i64(cfg, "map.goal.x", &i) == -1);
    CHECK(swarmrt_config_len(cfg, "map.bounds", &n) == 1 && n == 4);
    CHECK(swarmrt_config_len(cfg, "robots.lidar.angles_deg", &n) == 0);
    CHECK(swarmrt_config_str(cfg, "behaviour.kind", s, sizeof s) == 1 && strcmp(s, "goto") == 0);
    CHECK(swarmrt_config_str(cfg, "behaviour.kind", s, 4) == -1 && s[0] == '\0');
    swarmrt_config_free(cfg);

    CHECK(swarmrt_config_parse("x = [", err, sizeof err) == NULL);
    CHECK(strncmp(err, "config <text>:", 14) == 0);
    CHECK(swarmrt_config_load("/nonexistent/cfg.toml", err, sizeof err) == NULL);
    CHECK(strstr(err, "/nonexistent/cfg.toml") != NULL);
    CHECK(swarmrt_config_load(NULL, NULL, 0) == NULL);
    swarmrt_config_free(NULL);
    return 0;
}

static int messages(void) {
    swarmrt_observation_t obs;
    memset(&obs, 0, sizeof obs);
    obs.robot = 3;
    obs.tick = 7;
    swarmrt_command_t cmd;
    memset(&cmd, 0xab, sizeof cmd);
    swarmrt_robot_act(&obs, &cmd);
    CHECK(cmd.version == SWARMRT_PROTOCOL_VERSION && cmd.kind == SWARMRT_KIND_ACT);
    CHECK(cmd.robot == 3 && cmd.tick == 7 && cmd.v == 0.0 && cmd.omega == 0.0);
    CHECK(cmd.lidar_on == 0 && cmd.outbox_len == 0 && cmd.report_len == 0);

    CHECK(swarmrt_command_push_goto_beacon(&cmd, SWARMRT_BROADCAST, 1.5, -2.0, 0.25) == SWARMRT_OK);
    const swarmrt_frame_t *f = &cmd.outbox[0];
    double x = 1.5, got;
    CHECK(cmd.outbox_len == 1 && f->dst == SWARMRT_BROADCAST && f->len == 25);
    CHECK(f->payload[0] == SWARMRT_TAG_GOTO);
    memcpy(&got, &f->payload[1], 8); /* little-endian, as on every supported target */
    CHECK(got == x);
    double bx, by, bt;
    CHECK(swarmrt_frame_goto_beacon(f, &bx, &by, &bt) == 1);
    CHECK(bx == 1.5 && by == -2.0 && bt == 0.25);
    const uint8_t *bytes = NULL;
    size_t len = 0;
    CHECK(swarmrt_frame_opaque(f, &bytes, &len) == 0);

    CHECK(swarmrt_command_push_opaque(&cmd, 5, (const uint8_t *)"hi", 2) == SWARMRT_OK);
    f = &cmd.outbox[1];
    CHECK(f->dst == 5 && f->len == 3 && f->payload[0] == SWARMRT_OPAQUE_TAG);
    CHECK(swarmrt_frame_opaque(f, &bytes, &len) == 1 && len == 2 && memcmp(bytes, "hi", 2) == 0);
    CHECK(bytes == &f->payload[1]);
    CHECK(swarmrt_frame_goto_beacon(f, &bx, &by, &bt) == 0);
    uint8_t big[SWARMRT_MAX_PAYLOAD] = {0};
    CHECK(swarmrt_command_push_opaque(&cmd, 5, big, sizeof big) == SWARMRT_ERR_TOO_LARGE);
    CHECK(swarmrt_command_push_opaque(&cmd, 5, big, sizeof big - 1) == SWARMRT_OK);
    while (cmd.outbox_len < SWARMRT_MAX_OUTBOX) {
        CHECK(swarmrt_command_push_opaque(&cmd, 5, NULL, 0) == SWARMRT_OK);
    }
    CHECK(swarmrt_command_push_opaque(&cmd, 5, big, 1) == SWARMRT_ERR_OUTBOX_FULL);
    CHECK(swarmrt_command_push_goto_beacon(&cmd, 5, 0, 0, 0) == SWARMRT_ERR_OUTBOX_FULL);
    CHECK(swarmrt_command_push_opaque(NULL, 5, big, 1) == SWARMRT_ERR_NULL);
    CHECK(swarmrt_command_push_opaque(&cmd, 5, NULL, 1) == SWARMRT_ERR_NULL);
    return 0;
}

static int robot(void) {
    /* Not started by `swarm run`: opening says which variable is missing. */
    unsetenv("SWARMRT_RUN_ID");
    char err[256] = "";
    swarmrt_robot_t *r = swarmrt_robot_open(err, sizeof err);
    CHECK(r == NULL);
    CHECK(strstr(err, "SWARMRT_RUN_ID") != NULL);
    CHECK(swarmrt_robot_open(NULL, 0) == NULL);
    swarmrt_observation_t obs;
    CHECK(swarmrt_robot_next(NULL, &obs) == SWARMRT_NEXT_ERROR);
    CHECK(swarmrt_robot_send(NULL, NULL) == SWARMRT_ERR_NULL);
    CHECK(swarmrt_robot_error(NULL) != NULL);
    CHECK(swarmrt_robot_id(NULL) == UINT32_MAX);
    CHECK(swarmrt_robot_incarnation(NULL) == 0);
    CHECK(swarmrt_robot_run_id(NULL) == NULL);
    CHECK(swarmrt_robot_config_path(NULL) == NULL);
    CHECK(swarmrt_robot_storage_path(NULL) == NULL);
    CHECK(swarmrt_robot_config(NULL) == NULL);
    swarmrt_robot_close(NULL);
    CHECK(swarmrt_exit_code(SWARMRT_NEXT_SHUTDOWN) == SWARMRT_EXIT_SHUTDOWN);
    CHECK(swarmrt_exit_code(SWARMRT_NEXT_TERMINATED) == SWARMRT_EXIT_TERMINATED);
    CHECK(swarmrt_exit_code(SWARMRT_NEXT_ERROR) == SWARMRT_EXIT_FAILED);
    CHECK(swarmrt_exit_code(SWARMRT_NEXT_OBSERVATION) == SWARMRT_EXIT_FAILED);
    return 0;
}

int main(void) {
    if (config() || messages() || robot()) return 1;
    puts("ok");
    return 0;
}
