/* swarmrt shared-memory messages. GENERATED from the Rust types by
 * swarmrt_protocol::layout; do not edit (SWARMRT_UPDATE_BINDINGS=1 cargo test -p
 * swarmrt-protocol --test bindings rewrites it). See docs/robot-interface.md. */
#ifndef SWARMRT_MESSAGES_H
#define SWARMRT_MESSAGES_H

#include <stddef.h>
#include <stdint.h>

/* Every message's `version`. */
#define SWARMRT_PROTOCOL_VERSION 5u
/* Bytes in a radio frame's payload. */
#define SWARMRT_MAX_PAYLOAD 128u
/* Frames in one command's outbox. */
#define SWARMRT_MAX_OUTBOX 8u
/* Frames in one observation's inbox. */
#define SWARMRT_MAX_INBOX 32u
/* Lidar rays. */
#define SWARMRT_MAX_LIDAR_RAYS 64u
/* Neighbours seen by range-and-bearing. */
#define SWARMRT_MAX_NEIGHBOURS 32u
/* Bytes of a command's report (notes). */
#define SWARMRT_MAX_REPORT 256u
/* Destination of a broadcast frame. */
#define SWARMRT_BROADCAST 4294967295u
/* First payload byte of an opaque frame (raw bytes for robots of one kind). */
#define SWARMRT_OPAQUE_TAG 255u
/* Command kind: the robot's ports exist. */
#define SWARMRT_KIND_HELLO 1u
/* Command kind: the decision for `tick`. */
#define SWARMRT_KIND_ACT 2u
/* Command kind: a reaction within `tick` to a propagation round (built-in robots only so far). */
#define SWARMRT_KIND_REACT 3u
/* Observation state: moving and sensing. */
#define SWARMRT_STATE_ACTIVE 0u
/* Observation state: knocked down; answer, the command is ignored. */
#define SWARMRT_STATE_DOWN 1u
/* Observation state: its process is gone. */
#define SWARMRT_STATE_DEAD 2u
/* Observation state: frozen; do not answer. */
#define SWARMRT_STATE_FROZEN 3u
/* Observation state: restarting; do not answer. */
#define SWARMRT_STATE_RESTARTING 4u
/* Event id a robot notifies on the command event after each command. */
#define SWARMRT_EVENT_COMMAND 1u
/* Event id reserved for the world's own wake-ups. */
#define SWARMRT_EVENT_CONTROL 2u

/* One radio frame: sender, destination (or BROADCAST), payload. iceoryx2 type name "swarmrt::Frame"; 152 bytes, aligned to 8. */
typedef struct swarmrt_frame_t {
    uint32_t src;
    uint32_t dst;
    uint64_t sent_tick;
    uint16_t len;
    uint8_t payload[128];
    uint8_t _pad0[6];
} swarmrt_frame_t;
_Static_assert(sizeof(swarmrt_frame_t) == 152, "layout");
_Static_assert(offsetof(swarmrt_frame_t, src) == 0, "layout");
_Static_assert(offsetof(swarmrt_frame_t, dst) == 4, "layout");
_Static_assert(offsetof(swarmrt_frame_t, sent_tick) == 8, "layout");
_Static_assert(offsetof(swarmrt_frame_t, len) == 16, "layout");
_Static_assert(offsetof(swarmrt_frame_t, payload) == 18, "layout");
#define SWARMRT_FRAME_TYPE_NAME "swarmrt::Frame"

/* A robot seen by the range-and-bearing sensor. iceoryx2 type name "swarmrt::Neighbour"; 24 bytes, aligned to 8. */
typedef struct swarmrt_neighbour_t {
    uint32_t id;
    uint8_t _pad0[4];
    double range;
    double bearing;
} swarmrt_neighbour_t;
_Static_assert(sizeof(swarmrt_neighbour_t) == 24, "layout");
_Static_assert(offsetof(swarmrt_neighbour_t, id) == 0, "layout");
_Static_assert(offsetof(swarmrt_neighbour_t, range) == 8, "layout");
_Static_assert(offsetof(swarmrt_neighbour_t, bearing) == 16, "layout");
#define SWARMRT_NEIGHBOUR_TYPE_NAME "swarmrt::Neighbour"

/* Everything one robot senses at one tick (one slot of the observation sample). iceoryx2 type name "swarmrt::Observation"; 6224 bytes, aligned to 8. */
typedef struct swarmrt_observation_t {
    uint32_t version;
    uint32_t robot;
    uint64_t tick;
    uint8_t state;
    uint8_t reached;
    uint8_t goal_visible;
    uint8_t _pad0[1];
    uint16_t lidar_len;
    uint16_t neighbours_len;
    uint16_t inbox_len;
    uint8_t _pad1[6];
    double x;
    double y;
    double theta;
    double z;
    double goal_range;
    double goal_bearing;
    double lidar[64];
    swarmrt_neighbour_t neighbours[32];
    swarmrt_frame_t inbox[32];
} swarmrt_observation_t;
_Static_assert(sizeof(swarmrt_observation_t) == 6224, "layout");
_Static_assert(offsetof(swarmrt_observation_t, version) == 0, "layout");
_Static_assert(offsetof(swarmrt_observation_t, robot) == 4, "layout");
_Static_assert(offsetof(swarmrt_observation_t, tick) == 8, "layout");
_Static_assert(offsetof(swarmrt_observation_t, state) == 16, "layout");
_Static_assert(offsetof(swarmrt_observation_t, reached) == 17, "layout");
_Static_assert(offsetof(swarmrt_observation_t, goal_visible) == 18, "layout");
_Static_assert(offsetof(swarmrt_observation_t, lidar_len) == 20, "layout");
_Static_assert(offsetof(swarmrt_observation_t, neighbours_len) == 22, "layout");
_Static_assert(offsetof(swarmrt_observation_t, inbox_len) == 24, "layout");
_Static_assert(offsetof(swarmrt_observation_t, x) == 32, "layout");
_Static_assert(offsetof(swarmrt_observation_t, y) == 40, "layout");
_Static_assert(offsetof(swarmrt_observation_t, theta) == 48, "layout");
_Static_assert(offsetof(swarmrt_observation_t, z) == 56, "layout");
_Static_assert(offsetof(swarmrt_observation_t, goal_range) == 64, "layout");
_Static_assert(offsetof(swarmrt_observation_t, goal_bearing) == 72, "layout");
_Static_assert(offsetof(swarmrt_observation_t, lidar) == 80, "layout");
_Static_assert(offsetof(swarmrt_observation_t, neighbours) == 592, "layout");
_Static_assert(offsetof(swarmrt_observation_t, inbox) == 1360, "layout");
#define SWARMRT_OBSERVATION_TYPE_NAME "swarmrt::Observation"

/* User header of the observation sample: the tick and whether the run is over. iceoryx2 type name "swarmrt::ObservationHeader"; 16 bytes, aligned to 8. */
typedef struct swarmrt_observation_header_t {
    uint32_t version;
    uint32_t shutdown;
    uint64_t tick;
} swarmrt_observation_header_t;
_Static_assert(sizeof(swarmrt_observation_header_t) == 16, "layout");
_Static_assert(offsetof(swarmrt_observation_header_t, version) == 0, "layout");
_Static_assert(offsetof(swarmrt_observation_header_t, shutdown) == 4, "layout");
_Static_assert(offsetof(swarmrt_observation_header_t, tick) == 8, "layout");
#define SWARMRT_OBSERVATION_HEADER_TYPE_NAME "swarmrt::ObservationHeader"

/* A robot's answer to one observation (Hello first, then one Act per tick). iceoryx2 type name "swarmrt::Command"; 1552 bytes, aligned to 8. */
typedef struct swarmrt_command_t {
    uint32_t version;
    uint32_t robot;
    uint64_t tick;
    uint32_t kind;
    uint32_t pid;
    double v;
    double omega;
    double vx;
    double vy;
    double vz;
    uint8_t lidar_on;
    uint8_t _pad0[1];
    uint16_t outbox_len;
    uint16_t in_tick;
    uint8_t _pad1[2];
    swarmrt_frame_t outbox[8];
    uint16_t report_len;
    uint8_t report[256];
    uint8_t _pad2[6];
} swarmrt_command_t;
_Static_assert(sizeof(swarmrt_command_t) == 1552, "layout");
_Static_assert(offsetof(swarmrt_command_t, version) == 0, "layout");
_Static_assert(offsetof(swarmrt_command_t, robot) == 4, "layout");
_Static_assert(offsetof(swarmrt_command_t, tick) == 8, "layout");
_Static_assert(offsetof(swarmrt_command_t, kind) == 16, "layout");
_Static_assert(offsetof(swarmrt_command_t, pid) == 20, "layout");
_Static_assert(offsetof(swarmrt_command_t, v) == 24, "layout");
_Static_assert(offsetof(swarmrt_command_t, omega) == 32, "layout");
_Static_assert(offsetof(swarmrt_command_t, vx) == 40, "layout");
_Static_assert(offsetof(swarmrt_command_t, vy) == 48, "layout");
_Static_assert(offsetof(swarmrt_command_t, vz) == 56, "layout");
_Static_assert(offsetof(swarmrt_command_t, lidar_on) == 64, "layout");
_Static_assert(offsetof(swarmrt_command_t, outbox_len) == 66, "layout");
_Static_assert(offsetof(swarmrt_command_t, in_tick) == 68, "layout");
_Static_assert(offsetof(swarmrt_command_t, outbox) == 72, "layout");
_Static_assert(offsetof(swarmrt_command_t, report_len) == 1288, "layout");
_Static_assert(offsetof(swarmrt_command_t, report) == 1290, "layout");
#define SWARMRT_COMMAND_TYPE_NAME "swarmrt::Command"

#endif /* SWARMRT_MESSAGES_H */
