/* swarmrt radio and note envelope tags: the first byte of a postcard RadioMsg (and of
 * each Note of a report). GENERATED from the Rust registry by swarmrt_agent::wire; do
 * not edit (SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-agent --test agent wire_tags
 * rewrites it). The tags are declared in agent/src/behaviours/mod.rs and never move. */
#ifndef SWARMRT_TAGS_H
#define SWARMRT_TAGS_H

/* RadioMsg::Goto. */
#define SWARMRT_TAG_GOTO 0u
/* RadioMsg::Formation. */
#define SWARMRT_TAG_FORMATION 1u
/* RadioMsg::Flocking. */
#define SWARMRT_TAG_FLOCKING 2u
/* RadioMsg::Grouping. */
#define SWARMRT_TAG_GROUPING 3u
/* RadioMsg::Planner. */
#define SWARMRT_TAG_PLANNER 4u
/* RadioMsg::Chain. */
#define SWARMRT_TAG_CHAIN 5u
/* RadioMsg::Consensus. */
#define SWARMRT_TAG_CONSENSUS 6u

#endif /* SWARMRT_TAGS_H */
