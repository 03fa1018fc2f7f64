"""swarmrt radio and note envelope tags: the first byte of a postcard `RadioMsg`
(and of each `Note` of a report).

GENERATED from the Rust registry by swarmrt_agent::wire; do not edit
(SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-agent --test agent wire_tags rewrites it).
The tags are declared in agent/src/behaviours/mod.rs and never move.
"""

GOTO = 0
"""`RadioMsg::Goto`."""
FORMATION = 1
"""`RadioMsg::Formation`."""
FLOCKING = 2
"""`RadioMsg::Flocking`."""
GROUPING = 3
"""`RadioMsg::Grouping`."""
PLANNER = 4
"""`RadioMsg::Planner`."""
CHAIN = 5
"""`RadioMsg::Chain`."""
CONSENSUS = 6
"""`RadioMsg::Consensus`."""

TAGS = {
    "Goto": 0,
    "Formation": 1,
    "Flocking": 2,
    "Grouping": 3,
    "Planner": 4,
    "Chain": 5,
    "Consensus": 6,
}
"""Every tag by its Rust variant name."""
