/* The go-to robot in C: a port of agent/src/behaviours/goto/ that decides bit for bit what
 * the Rust robot decides, so a run of C robots writes the same trajectory.csv and
 * events.jsonl as a run of Rust ones.
 *
 * Build (from the workspace root):
 *
 *   cargo build --release -p swarmrt-c
 *   cc -std=c11 -O2 -ffp-contract=off -I bindings/c/include examples/c/goto.c \
 *      target/release/libswarmrt.a -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc -o goto-c
 *   target/release/swarm run configs/goto_simple.toml \
 *      --set "robots.program=[\"$PWD/goto-c\"]"
 *
 * Bit for bit means: the same IEEE operations in the same order as the Rust code. No
 * -ffast-math; -ffp-contract=off so that no a * b + c becomes a fused multiply-add (Rust
 * never fuses); atan2, cos, fmod, sqrt from the same libm the Rust robot calls; Rust's
 * f64::min/max are fmin/fmax (a NaN loses), `%` is fmod, powi(2) is x * x and to_radians is
 * x * (pi / 180). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swarmrt.h"

/* Rust's std::f64::consts::PI (strict C11 <math.h> does not define M_PI). */
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Distance to the slot under which the robot stops. */
#define ARRIVE 0.05
/* Half-width of the sector ahead that counts for avoidance (`70.0 * PI / 180.0` in Rust). */
#define AHEAD (70.0 * M_PI / 180.0)
/* Grid candidates nearest_grid_points considers at most. */
#define MAX_GRID_CANDIDATES 4000000

/* [behaviour] of kind "goto" (agent/src/behaviours/goto/params.rs). */
typedef struct {
    double speed;
    double avoid_distance;
    int64_t beacon_period;
    double slot_spacing;
} goto_params_t;

/* One robot's go-to state (the Rust `Goto`). */
typedef struct {
    uint32_t id;
    goto_params_t params;
    double ray_angle[SWARMRT_MAX_LIDAR_RAYS];
    double radius, dt, max_speed, max_turn;
    double slot_x, slot_y;
    double goal_x, goal_y, goal_radius;
    int64_t count;
    double bounds[4];
    /* The side (+1 left, -1 right) committed to while going around an obstacle; 0 = none. */
    double avoid_side;
} goto_t;

static char error_text[512];

static int fail(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(error_text, sizeof error_text, fmt, ap);
    va_end(ap);
    return -1;
}

static int need_f64(const swarmrt_config_t *cfg, const char *key, double *out) {
    int r = swarmrt_config_f64(cfg, key, out);
    return r == 1 ? 0 : fail("config key %s: %s", key, r == 0 ? "missing" : "expected a number");
}

static int need_i64(const swarmrt_config_t *cfg, const char *key, int64_t *out) {
    int r = swarmrt_config_i64(cfg, key, out);
    return r == 1 ? 0 : fail("config key %s: %s", key, r == 0 ? "missing" : "expected an integer");
}

/* Rust's x.clamp(lo, hi). */
static double clamp(double x, double lo, double hi) {
    if (x < lo) x = lo;
    if (x > hi) x = hi;
    return x;
}

/* scenario/src/angle.rs: wraps an angle into (-pi, pi]. */
static double wrap_angle(double a) {
    a = fmod(a, 2.0 * M_PI);
    if (a <= -M_PI) {
        a += 2.0 * M_PI;
    } else if (a > M_PI) {
        a -= 2.0 * M_PI;
    }
    return a;
}

/* Rust's `f as i64`: saturating, NaN is 0. */
static int64_t f64_to_i64(double f) {
    if (f != f) return 0;
    if (f <= -9223372036854775808.0) return INT64_MIN;
    if (f >= 9223372036854775808.0) return INT64_MAX;
    return (int64_t)f;
}

/* One grid cell, ordered by (i*i + j*j, j, i) as scenario/src/layout.rs orders them. */
typedef struct {
    int64_t d, j, i;
} cell_t;

static int cell_cmp(const void *pa, const void *pb) {
    const cell_t *a = pa, *b = pb;
    if (a->d != b->d) return a->d < b->d ? -1 : 1;
    if (a->j != b->j) return a->j < b->j ? -1 : 1;
    if (a->i != b->i) return a->i < b->i ? -1 : 1;
    return 0;
}

/* scenario/src/layout.rs nearest_grid_points with every point accepted: point `k` of the `n`
 * grid points nearest `centre`, at least `margin` inside `bounds`. 1 with it in *x, *y; 0
 * when fewer than n qualify (or k >= n); -1 when out of memory. */
static int nearest_grid_point(int64_t n, uint32_t k, double cx, double cy, double spacing,
                              const double bounds[4], double margin, double *x, double *y) {
    if (n <= 0 || (int64_t)k >= n) return 0;
    if (!isfinite(spacing) || spacing <= 0.0) return 0;
    double lo_i = ceil((bounds[0] + margin - cx) / spacing);
    double hi_i = floor((bounds[2] - margin - cx) / spacing);
    double lo_j = ceil((bounds[1] + margin - cy) / spacing);
    double hi_j = floor((bounds[3] - margin - cy) / spacing);
    if (!(hi_i >= lo_i && hi_j >= lo_j) ||
        (hi_i - lo_i + 1.0) * (hi_j - lo_j + 1.0) > (double)MAX_GRID_CANDIDATES) {
        return 0;
    }
    int64_t li = f64_to_i64(lo_i), hi = f64_to_i64(hi_i);
    int64_t lj = f64_to_i64(lo_j), hj = f64_to_i64(hi_j);
    size_t cells_len = (size_t)((hi - li + 1) * (hj - lj + 1));
    cell_t *cells = malloc(cells_len * sizeof *cells);
    if (!cells) return -1;
    size_t c = 0;
    for (int64_t j = lj; j <= hj; j++) {
        for (int64_t i = li; i <= hi; i++) {
            /* Wrapping like Rust's release build (never near overflow for real maps). */
            uint64_t d = (uint64_t)i * (uint64_t)i + (uint64_t)j * (uint64_t)j;
            cells[c].d = (int64_t)d;
            cells[c].j = j;
            cells[c].i = i;
            c++;
        }
    }
    qsort(cells, c, sizeof *cells, cell_cmp);
    int64_t found = 0;
    int ok = 0;
    for (size_t m = 0; m < c; m++) {
        double px = cx + spacing * (double)cells[m].i;
        double py = cy + spacing * (double)cells[m].j;
        if (px - margin > bounds[0] && px + margin < bounds[2] && py - margin > bounds[1] &&
            py + margin < bounds[3]) {
            if (found == (int64_t)k) {
                *x = px;
                *y = py;
                ok = 1;
            }
            found++;
            if (found == n) break;
        }
    }
    free(cells);
    /* Rust returns None (and the robot heads for the goal) unless all n points qualify. */
    return found == n ? ok : 0;
}

/* The Rust `Goto::slot_around`: this robot's slot around the goal, or the goal itself. */
static int slot_around(goto_t *g) {
    double spacing = fmax(g->params.slot_spacing, 2.5 * g->radius);
    double x = 0.0, y = 0.0;
    int r = nearest_grid_point(g->count, g->id, g->goal_x, g->goal_y, spacing, g->bounds,
                               g->radius, &x, &y);
    if (r < 0) return fail("out of memory");
    if (r == 1) {
        g->slot_x = x;
        g->slot_y = y;
    } else {
        g->slot_x = g->goal_x;
        g->slot_y = g->goal_y;
    }
    return 0;
}

/* Config::start_group (scenario/src/layout.rs): contiguous blocks of ids. */
static int start_group(const swarmrt_config_t *cfg, uint32_t id, int64_t count, size_t *out) {
    size_t sizes = 0, groups = 0;
    if (swarmrt_config_len(cfg, "robots.start.group_sizes", &sizes) < 0 ||
        swarmrt_config_len(cfg, "robots.start.groups", &groups) < 0) {
        return fail("config key robots.start.group_sizes/groups: expected arrays");
    }
    if (sizes > 0) {
        uint64_t end = 0;
        for (size_t g = 0; g < sizes; g++) {
            char key[64];
            int64_t size;
            snprintf(key, sizeof key, "robots.start.group_sizes[%zu]", g);
            if (need_i64(cfg, key, &size) != 0) return -1;
            end += (uint64_t)size;
            if ((uint64_t)id < end) {
                *out = g;
                return 0;
            }
        }
        *out = sizes - 1;
        return 0;
    }
    uint64_t n = count > 1 ? (uint64_t)count : 1;
    uint64_t gs = groups > 1 ? groups : 1;
    uint64_t i = (uint64_t)id < n - 1 ? (uint64_t)id : n - 1;
    *out = (size_t)(i * gs / n);
    return 0;
}

/* Config::goal_of: the start group's own goal, else map.goal (same radius). */
static int goal_of(const swarmrt_config_t *cfg, goto_t *g) {
    if (need_f64(cfg, "map.goal.x", &g->goal_x) || need_f64(cfg, "map.goal.y", &g->goal_y) ||
        need_f64(cfg, "map.goal.radius", &g->goal_radius)) {
        return -1;
    }
    size_t group = 0;
    if (start_group(cfg, g->id, g->count, &group) != 0) return -1;
    char kx[80], ky[80];
    snprintf(kx, sizeof kx, "robots.start.groups[%zu].goal[0]", group);
    snprintf(ky, sizeof ky, "robots.start.groups[%zu].goal[1]", group);
    double x, y;
    if (swarmrt_config_f64(cfg, kx, &x) == 1 && swarmrt_config_f64(cfg, ky, &y) == 1) {
        g->goal_x = x;
        g->goal_y = y;
    }
    return 0;
}

/* LidarConfig::ray_angle for every ray (scenario/src/config.rs). */
static int ray_angles(const swarmrt_config_t *cfg, double out[SWARMRT_MAX_LIDAR_RAYS]) {
    int64_t rays;
    double fov_deg;
    size_t given = 0;
    if (need_i64(cfg, "robots.lidar.rays", &rays) || need_f64(cfg, "robots.lidar.fov_deg", &fov_deg))
        return -1;
    if (swarmrt_config_len(cfg, "robots.lidar.angles_deg", &given) < 0)
        return fail("config key robots.lidar.angles_deg: expected an array");
    for (size_t k = 0; k < SWARMRT_MAX_LIDAR_RAYS; k++) {
        if (k < given) {
            char key[64];
            double a;
            snprintf(key, sizeof key, "robots.lidar.angles_deg[%zu]", k);
            if (need_f64(cfg, key, &a) != 0) return -1;
            out[k] = a * (M_PI / 180.0);
            continue;
        }
        uint64_t n = rays > 1 ? (uint64_t)rays : 1;
        if (n == 1) {
            out[k] = 0.0;
            continue;
        }
        double fov = fov_deg * (M_PI / 180.0);
        double step = fov_deg >= 360.0 ? fov / (double)n : fov / (double)(n - 1);
        out[k] = -fov / 2.0 + step * (double)k;
    }
    return 0;
}

/* Goto::new. */
static int goto_init(goto_t *g, const swarmrt_config_t *cfg, uint32_t id) {
    memset(g, 0, sizeof *g);
    g->id = id;
    if (need_f64(cfg, "behaviour.speed", &g->params.speed) ||
        need_f64(cfg, "behaviour.avoid_distance", &g->params.avoid_distance) ||
        need_i64(cfg, "behaviour.beacon_period", &g->params.beacon_period) ||
        need_f64(cfg, "behaviour.slot_spacing", &g->params.slot_spacing) ||
        need_f64(cfg, "robots.radius", &g->radius) || need_f64(cfg, "scenario.dt", &g->dt) ||
        need_f64(cfg, "robots.max_speed", &g->max_speed) ||
        need_f64(cfg, "robots.max_turn_rate", &g->max_turn) ||
        need_i64(cfg, "robots.count", &g->count)) {
        return -1;
    }
    for (int b = 0; b < 4; b++) {
        char key[32];
        snprintf(key, sizeof key, "map.bounds[%d]", b);
        if (need_f64(cfg, key, &g->bounds[b]) != 0) return -1;
    }
    if (ray_angles(cfg, g->ray_angle) != 0 || goal_of(cfg, g) != 0) return -1;
    return slot_around(g);
}

/* Goto::step: fills the command of an ACTIVE robot (`cmd` is a fresh swarmrt_robot_act). */
static void goto_step(goto_t *g, const swarmrt_observation_t *obs, swarmrt_command_t *cmd) {
    cmd->lidar_on = 1;
    const goto_params_t p = g->params;
    if (p.beacon_period > 0 && (obs->tick + g->id) % (uint64_t)p.beacon_period == 0) {
        /* A full outbox drops the frame, as the radio would (it is empty here). */
        (void)swarmrt_command_push_goto_beacon(cmd, SWARMRT_BROADCAST, obs->x, obs->y,
                                               obs->theta);
    }

    double dx = g->slot_x - obs->x, dy = g->slot_y - obs->y;
    double dist = sqrt(dx * dx + dy * dy);
    if (dist < ARRIVE) return;
    double err = wrap_angle(atan2(dy, dx) - obs->theta);
    double omega = 2.0 * err;
    /* Slow down when facing away and when close, so the robot does not orbit its slot. */
    double v = p.speed * fmax(cos(err), 0.0) * fmin(dist / (4.0 * g->radius), 1.0);

    /* Avoidance: nearest return in the sector ahead, which side is more open, and what the
     * ray closest to the slot's direction sees. */
    double nearest = INFINITY, left = 0.0, right = 0.0;
    double toward_slot = INFINITY, best = INFINITY;
    size_t rays = obs->lidar_len < SWARMRT_MAX_LIDAR_RAYS ? obs->lidar_len : SWARMRT_MAX_LIDAR_RAYS;
    for (size_t k = 0; k < rays; k++) {
        double d = obs->lidar[k];
        double a = g->ray_angle[k];
        if (fabs(a) <= AHEAD) nearest = fmin(nearest, d);
        if (a > 0.0) {
            left += d;
        } else if (a < 0.0) {
            right += d;
        }
        if (fabs(a - err) < best) {
            best = fabs(a - err);
            toward_slot = d;
        }
    }
    double gx = obs->x - g->goal_x, gy = obs->y - g->goal_y;
    int in_goal_area = sqrt(gx * gx + gy * gy) < g->goal_radius * 0.9;
    /* Only obstacles closer than the slot matter. */
    if (nearest < p.avoid_distance && nearest < dist) {
        /* Inside the goal area but blocked, most likely by a robot parked at its slot:
         * park here instead of circling. */
        if (in_goal_area) return;
        /* Commit to one side until the way to the slot is open. */
        if (g->avoid_side == 0.0) g->avoid_side = left >= right ? 1.0 : -1.0;
        double side = g->avoid_side;
        double urgency = 1.0 - fmax(nearest - g->radius, 0.0) /
                                   fmax(p.avoid_distance - g->radius, 1e-6);
        omega = side * g->max_turn * clamp(urgency, 0.3, 1.0);
        v = p.speed * clamp(1.0 - urgency, 0.0, 1.0);
        if (nearest < g->radius + 0.1) v = 0.0;
    } else if (g->avoid_side != 0.0) {
        double side = g->avoid_side;
        if (toward_slot < fmax(p.avoid_distance, fmin(dist, 1.5 * p.avoid_distance)) &&
            best < AHEAD * 2.0) {
            /* The slot is still behind the obstacle: follow its edge, bending back toward
             * it slowly so the robot goes around instead of away. */
            omega = -side * 0.3 * g->max_turn;
            v = p.speed;
        } else {
            g->avoid_side = 0.0;
        }
    }

    /* Never overshoot the slot within one tick. */
    cmd->v = clamp(fmin(v, dist / g->dt), 0.0, g->max_speed);
    cmd->omega = clamp(omega, -g->max_turn, g->max_turn);
}

int main(void) {
    char err[512];
    swarmrt_robot_t *robot = swarmrt_robot_open(err, sizeof err);
    if (!robot) {
        fprintf(stderr, "goto-c: %s\n", err);
        return SWARMRT_EXIT_FAILED;
    }
    uint32_t id = swarmrt_robot_id(robot);
    goto_t g;
    if (goto_init(&g, swarmrt_robot_config(robot), id) != 0) {
        fprintf(stderr, "goto-c: robot %u: %s (in %s)\n", id, error_text,
                swarmrt_robot_config_path(robot));
        swarmrt_robot_close(robot);
        return 2;
    }
    swarmrt_observation_t obs;
    swarmrt_command_t cmd;
    int rc;
    while ((rc = swarmrt_robot_next(robot, &obs)) == SWARMRT_NEXT_OBSERVATION) {
        swarmrt_robot_act(&obs, &cmd);
        /* A DOWN robot answers with the stopped command; the world ignores it. */
        if (obs.state == SWARMRT_STATE_ACTIVE) goto_step(&g, &obs, &cmd);
        if (swarmrt_robot_send(robot, &cmd) != SWARMRT_OK) {
            rc = SWARMRT_NEXT_ERROR;
            break;
        }
    }
    if (rc == SWARMRT_NEXT_ERROR) {
        fprintf(stderr, "goto-c: robot %u: %s\n", id, swarmrt_robot_error(robot));
    }
    swarmrt_robot_close(robot);
    return swarmrt_exit_code(rc);
}
