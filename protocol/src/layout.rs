//! The byte layout of every shared-memory message, read from the Rust types themselves, and
//! the C header and Python module generated from it (`bindings/`).
//!
//! A robot in another language mirrors [`Observation`] and [`Command`] byte for byte. Those
//! mirrors are never kept by hand: [`MESSAGES`] lists each struct's fields with the offsets
//! `offset_of!` gives, the field list is checked exhaustive by the compiler (a destructuring
//! pattern without `..`), and `bindings/c/include/swarmrt_messages.h` and
//! `bindings/python/swarmrt/_messages.py` are this module's output, compared with it by a test
//! (`SWARMRT_UPDATE_BINDINGS=1` rewrites them).

use core::mem::{align_of, offset_of, size_of};

use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;

use crate::messages::*;
use crate::services::{EVENT_COMMAND, EVENT_CONTROL};

/// A field's type as C and Python see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ty {
    /// `uint8_t`.
    U8,
    /// `uint16_t`.
    U16,
    /// `uint32_t`.
    U32,
    /// `uint64_t`.
    U64,
    /// `double`.
    F64,
    /// One of the structs of [`MESSAGES`], by its Rust name.
    Struct(&'static str),
    /// A fixed array.
    Array(&'static Ty, usize),
}

impl Ty {
    fn c(&self) -> String {
        match self {
            Ty::U8 => "uint8_t".into(),
            Ty::U16 => "uint16_t".into(),
            Ty::U32 => "uint32_t".into(),
            Ty::U64 => "uint64_t".into(),
            Ty::F64 => "double".into(),
            Ty::Struct(s) => c_name(s),
            Ty::Array(t, _) => t.c(),
        }
    }

    fn py(&self) -> String {
        match self {
            Ty::U8 => "ctypes.c_uint8".into(),
            Ty::U16 => "ctypes.c_uint16".into(),
            Ty::U32 => "ctypes.c_uint32".into(),
            Ty::U64 => "ctypes.c_uint64".into(),
            Ty::F64 => "ctypes.c_double".into(),
            Ty::Struct(s) => s.to_string(),
            Ty::Array(t, n) => format!("{} * {n}", t.py()),
        }
    }

    /// The name a layout test prints for this type: `u8`, `f64`, `Frame`, `Frame[32]`.
    pub fn name(&self) -> String {
        match self {
            Ty::U8 => "u8".into(),
            Ty::U16 => "u16".into(),
            Ty::U32 => "u32".into(),
            Ty::U64 => "u64".into(),
            Ty::F64 => "f64".into(),
            Ty::Struct(s) => s.to_string(),
            Ty::Array(t, n) => format!("{}[{n}]", t.name()),
        }
    }
}

/// A Rust type that has a [`Ty`].
pub trait CType {
    /// Its type.
    const TY: Ty;
}

macro_rules! c_types {
    ($($t:ty => $v:expr),+ $(,)?) => { $(impl CType for $t { const TY: Ty = $v; })+ };
}
c_types! {
    u8 => Ty::U8, u16 => Ty::U16, u32 => Ty::U32, u64 => Ty::U64, f64 => Ty::F64,
    Frame => Ty::Struct("Frame"), Neighbour => Ty::Struct("Neighbour"),
}

impl<T: CType, const N: usize> CType for [T; N] {
    const TY: Ty = Ty::Array(&T::TY, N);
}

/// One field: its name, type and byte offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// The Rust (and C, and Python) field name.
    pub name: &'static str,
    /// Its type.
    pub ty: Ty,
    /// Its offset in bytes from the start of the struct.
    pub offset: usize,
    /// Its size in bytes.
    pub size: usize,
}

/// One `#[repr(C)]` message struct.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Struct {
    /// The Rust name (also the Python class name).
    pub name: &'static str,
    /// The type name iceoryx2 compares when a port opens a service (`#[type_name]`).
    pub type_name: &'static str,
    /// `size_of`.
    pub size: usize,
    /// `align_of`.
    pub align: usize,
    /// Every field, in declaration order.
    pub fields: Vec<Field>,
    /// The Rust doc line of the struct, for the generated comments.
    pub doc: &'static str,
}

fn field_of<S, T: CType>(_: fn(&S) -> &T) -> (Ty, usize) {
    (T::TY, size_of::<T>())
}

macro_rules! message {
    ($t:ident, $doc:expr, { $($f:ident),+ $(,)? }) => {{
        // Fails to compile when a field is added to the Rust struct but not listed here.
        #[allow(unused_variables, clippy::redundant_locals)]
        let _exhaustive = |v: &$t| {
            let $t { $($f: _),+ } = v;
        };
        Struct {
            name: stringify!($t),
            // SAFETY: `type_name` only returns the `#[type_name]` string of the derive.
            type_name: unsafe { <$t as ZeroCopySend>::type_name() },
            size: size_of::<$t>(),
            align: align_of::<$t>(),
            fields: vec![$({
                let (ty, size) = field_of(|s: &$t| &s.$f);
                Field { name: stringify!($f), ty, offset: offset_of!($t, $f), size }
            }),+],
            doc: $doc,
        }
    }};
}

/// Every struct a robot exchanges with the world, dependencies first.
pub fn messages() -> Vec<Struct> {
    vec![
        message!(Frame, "One radio frame: sender, destination (or BROADCAST), payload.", {
            src, dst, sent_tick, len, payload
        }),
        message!(Neighbour, "A robot seen by the range-and-bearing sensor.", {
            id, range, bearing
        }),
        message!(Observation, "Everything one robot senses at one tick (one slot of the observation sample).", {
            version, robot, tick, state, reached, goal_visible, lidar_len, neighbours_len,
            inbox_len, x, y, theta, z, goal_range, goal_bearing, lidar, neighbours, inbox
        }),
        message!(ObservationHeader, "User header of the observation sample: the tick and whether the run is over.", {
            version, shutdown, tick
        }),
        message!(Command, "A robot's answer to one observation (Hello first, then one Act per tick).", {
            version, robot, tick, kind, pid, v, omega, vx, vy, vz, lidar_on, outbox_len,
            in_tick, outbox, report_len, report
        }),
    ]
}

/// The integer constants a foreign robot needs, with one line each on what they are.
pub fn constants() -> Vec<(&'static str, u64, &'static str)> {
    vec![
        (
            "PROTOCOL_VERSION",
            PROTOCOL_VERSION as u64,
            "Every message's `version`.",
        ),
        (
            "MAX_PAYLOAD",
            MAX_PAYLOAD as u64,
            "Bytes in a radio frame's payload.",
        ),
        (
            "MAX_OUTBOX",
            MAX_OUTBOX as u64,
            "Frames in one command's outbox.",
        ),
        (
            "MAX_INBOX",
            MAX_INBOX as u64,
            "Frames in one observation's inbox.",
        ),
        ("MAX_LIDAR_RAYS", MAX_LIDAR_RAYS as u64, "Lidar rays."),
        (
            "MAX_NEIGHBOURS",
            MAX_NEIGHBOURS as u64,
            "Neighbours seen by range-and-bearing.",
        ),
        (
            "MAX_REPORT",
            MAX_REPORT as u64,
            "Bytes of a command's report (notes).",
        ),
        (
            "BROADCAST",
            BROADCAST as u64,
            "Destination of a broadcast frame.",
        ),
        (
            "OPAQUE_TAG",
            OPAQUE_TAG as u64,
            "First payload byte of an opaque frame (raw bytes for robots of one kind).",
        ),
        (
            "KIND_HELLO",
            CommandKind::Hello as u64,
            "Command kind: the robot's ports exist.",
        ),
        (
            "KIND_ACT",
            CommandKind::Act as u64,
            "Command kind: the decision for `tick`.",
        ),
        (
            "KIND_REACT",
            CommandKind::React as u64,
            "Command kind: a reaction within `tick` to a propagation round (built-in robots only so far).",
        ),
        (
            "STATE_ACTIVE",
            RobotState::Active as u64,
            "Observation state: moving and sensing.",
        ),
        (
            "STATE_DOWN",
            RobotState::Down as u64,
            "Observation state: knocked down; answer, the command is ignored.",
        ),
        (
            "STATE_DEAD",
            RobotState::Dead as u64,
            "Observation state: its process is gone.",
        ),
        (
            "STATE_FROZEN",
            RobotState::Frozen as u64,
            "Observation state: frozen; do not answer.",
        ),
        (
            "STATE_RESTARTING",
            RobotState::Restarting as u64,
            "Observation state: restarting; do not answer.",
        ),
        (
            "EVENT_COMMAND",
            EVENT_COMMAND as u64,
            "Event id a robot notifies on the command event after each command.",
        ),
        (
            "EVENT_CONTROL",
            EVENT_CONTROL as u64,
            "Event id reserved for the world's own wake-ups.",
        ),
    ]
}

fn c_name(rust: &str) -> String {
    let mut s = String::from("swarmrt_");
    for (i, ch) in rust.chars().enumerate() {
        if ch.is_ascii_uppercase() && i > 0 {
            s.push('_');
        }
        s.push(ch.to_ascii_lowercase());
    }
    s.push_str("_t");
    s
}

/// The C header (`bindings/c/include/swarmrt_messages.h`).
pub fn c_header() -> String {
    let mut out = String::new();
    out.push_str(
        "/* swarmrt shared-memory messages. GENERATED from the Rust types by\n \
         * swarmrt_protocol::layout; do not edit (SWARMRT_UPDATE_BINDINGS=1 cargo test -p\n \
         * swarmrt-protocol --test bindings rewrites it). See docs/robot-interface.md. */\n\
         #ifndef SWARMRT_MESSAGES_H\n#define SWARMRT_MESSAGES_H\n\n\
         #include <stddef.h>\n#include <stdint.h>\n\n",
    );
    for (name, value, doc) in constants() {
        out.push_str(&format!(
            "/* {doc} */\n#define SWARMRT_{name} {value}u{}\n",
            if value > u32::MAX as u64 { "ll" } else { "" }
        ));
    }
    for s in messages() {
        out.push_str(&format!(
            "\n/* {} iceoryx2 type name \"{}\"; {} bytes, aligned to {}. */\ntypedef struct {} {{\n",
            s.doc,
            s.type_name,
            s.size,
            s.align,
            c_name(s.name)
        ));
        let mut at = 0;
        let mut pad = 0;
        for f in &s.fields {
            if f.offset > at {
                out.push_str(&format!("    uint8_t _pad{pad}[{}];\n", f.offset - at));
                pad += 1;
            }
            match f.ty {
                Ty::Array(_, n) => {
                    out.push_str(&format!("    {} {}[{n}];\n", f.ty.c(), f.name));
                }
                _ => out.push_str(&format!("    {} {};\n", f.ty.c(), f.name)),
            }
            at = f.offset + f.size;
        }
        if s.size > at {
            out.push_str(&format!("    uint8_t _pad{pad}[{}];\n", s.size - at));
        }
        out.push_str(&format!("}} {};\n", c_name(s.name)));
        out.push_str(&format!(
            "_Static_assert(sizeof({}) == {}, \"layout\");\n",
            c_name(s.name),
            s.size
        ));
        for f in &s.fields {
            out.push_str(&format!(
                "_Static_assert(offsetof({}, {}) == {}, \"layout\");\n",
                c_name(s.name),
                f.name,
                f.offset
            ));
        }
        out.push_str(&format!(
            "#define SWARMRT_{}_TYPE_NAME \"{}\"\n",
            c_name(s.name)
                .trim_start_matches("swarmrt_")
                .trim_end_matches("_t")
                .to_ascii_uppercase(),
            s.type_name
        ));
    }
    out.push_str("\n#endif /* SWARMRT_MESSAGES_H */\n");
    out
}

/// The Python module (`bindings/python/swarmrt/_messages.py`): ctypes mirrors whose
/// `type_name()` is what iceoryx2 compares.
pub fn python_module() -> String {
    let mut out = String::new();
    out.push_str(
        "\"\"\"swarmrt shared-memory messages as ctypes structures.\n\n\
         GENERATED from the Rust types by swarmrt_protocol::layout; do not edit\n\
         (SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-protocol --test bindings rewrites it).\n\
         See docs/robot-interface.md.\n\"\"\"\n\nimport ctypes\n\n",
    );
    for (name, value, doc) in constants() {
        out.push_str(&format!("{name} = {value}\n\"\"\"{doc}\"\"\"\n"));
    }
    for s in messages() {
        out.push_str(&format!(
            "\n\nclass {}(ctypes.Structure):\n    \"\"\"{} {} bytes.\"\"\"\n\n    _fields_ = [\n",
            s.name, s.doc, s.size
        ));
        let mut at = 0;
        let mut pad = 0;
        for f in &s.fields {
            if f.offset > at {
                out.push_str(&format!(
                    "        (\"_pad{pad}\", ctypes.c_uint8 * {}),\n",
                    f.offset - at
                ));
                pad += 1;
            }
            out.push_str(&format!("        (\"{}\", {}),\n", f.name, f.ty.py()));
            at = f.offset + f.size;
        }
        if s.size > at {
            out.push_str(&format!(
                "        (\"_pad{pad}\", ctypes.c_uint8 * {}),\n",
                s.size - at
            ));
        }
        out.push_str(&format!(
            "    ]\n\n    @staticmethod\n    def type_name() -> str:\n        \"\"\"The name iceoryx2 compares when a port opens the service.\"\"\"\n        return \"{}\"\n",
            s.type_name
        ));
    }
    out.push_str("\n\nLAYOUT = {\n");
    for s in messages() {
        out.push_str(&format!("    \"{}\": {},\n", s.name, s.size));
    }
    out.push_str("}\n\"\"\"Size in bytes of each struct, as Rust lays it out.\"\"\"\n");
    out
}

/// What a layout test on the other side prints and compares: one line per struct
/// (`Observation size 6216 align 8 type swarmrt::Observation`) and per field
/// (`Observation.x offset 40 size 8`).
pub fn layout_lines() -> Vec<String> {
    let mut out = Vec::new();
    for s in messages() {
        out.push(format!(
            "{} size {} align {} type {}",
            s.name, s.size, s.align, s.type_name
        ));
        for f in &s.fields {
            out.push(format!(
                "{}.{} offset {} size {}",
                s.name, f.name, f.offset, f.size
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_tile_each_struct_in_order() {
        for s in messages() {
            let mut at = 0;
            for f in &s.fields {
                assert!(f.offset >= at, "{}.{} overlaps", s.name, f.name);
                at = f.offset + f.size;
            }
            assert!(at <= s.size, "{} ends past its size", s.name);
        }
        let obs = messages()
            .into_iter()
            .find(|s| s.name == "Observation")
            .unwrap();
        assert_eq!(obs.size % obs.align, 0);
        assert_eq!(obs.type_name, "swarmrt::Observation");
    }

    #[test]
    fn c_names_are_snake_case() {
        assert_eq!(c_name("ObservationHeader"), "swarmrt_observation_header_t");
    }
}
