//! The envelopes' wire tags: the first byte of every radio frame ([`RadioMsg`]) and of every
//! note in a report ([`Note`]).
//!
//! A derived serde enum writes its variant *index*, so appending a behaviour would renumber
//! the consensus layer's variant and silently break every robot written in another language.
//! Instead each registry line names its tag (`Goto = 0 => goto::Goto`), the consensus layer
//! keeps [`CONSENSUS_TAG`], and the envelopes' serde impls write [`WireTag`]'s value where
//! the derive wrote the index: postcard writes it as one varint byte equal to it (every tag is
//! below 128), byte for byte what the derive wrote when the tags equalled the indices.
//!
//! Checks: two variants with one tag do not compile (the tags are the explicit discriminants
//! of [`WireTag`]), nor does a tag of 128 or more (which would take two bytes and could start
//! with [`OPAQUE_TAG`]). The constants of other languages are generated from [`tags`]
//! ([`python_module`], [`c_header`]) and compared with the committed files by
//! `agent/tests/agent/wire_tags.rs`.
//!
//! [`RadioMsg`]: crate::RadioMsg
//! [`Note`]: crate::Note

use std::fmt;

use serde::de::{self, Unexpected};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use swarmrt_protocol::OPAQUE_TAG;

pub use crate::behaviours::WireTag;

/// The consensus layer's tag in both envelopes. Fixed, not its position: it was the variant
/// index (6) when the tags became explicit, and a new behaviour takes a new tag instead.
pub const CONSENSUS_TAG: u8 = 6;

// Every tag is one postcard byte and never an opaque frame's first byte.
const _: () = {
    let mut i = 0;
    while i < WireTag::ALL.len() {
        let tag = WireTag::ALL[i] as u8;
        assert!(tag < 0x80, "a wire tag must be below 128 (one varint byte)");
        assert!(tag != OPAQUE_TAG, "a wire tag must not be OPAQUE_TAG");
        i += 1;
    }
};

impl WireTag {
    /// The tag whose value is `n`, if any.
    pub fn from_u64(n: u64) -> Option<WireTag> {
        WireTag::ALL.iter().copied().find(|t| *t as u64 == n)
    }

    /// The tag of the variant named `name` (`"Goto"`, `"Consensus"`), if any.
    pub fn from_name(name: &str) -> Option<WireTag> {
        WireTag::ALL.iter().copied().find(|t| t.name() == name)
    }
}

/// Reads a variant identifier: its tag (postcard) or its name (self-describing formats).
impl<'de> Deserialize<'de> for WireTag {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<WireTag, D::Error> {
        struct Visitor;
        impl de::Visitor<'_> for Visitor {
            type Value = WireTag;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a wire tag of the radio or note envelope")
            }
            fn visit_u64<E: de::Error>(self, n: u64) -> Result<WireTag, E> {
                WireTag::from_u64(n).ok_or_else(|| E::invalid_value(Unexpected::Unsigned(n), &self))
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<WireTag, E> {
                WireTag::from_name(s).ok_or_else(|| E::unknown_variant(s, WireTag::NAMES))
            }
        }
        d.deserialize_identifier(Visitor)
    }
}

/// Writes `body` as variant `tag` of the envelope `envelope`: as the derive would, with the
/// tag in place of the variant index.
pub fn serialize_variant<S: Serializer, T: Serialize + ?Sized>(
    s: S,
    envelope: &'static str,
    tag: WireTag,
    body: &T,
) -> Result<S::Ok, S::Error> {
    s.serialize_newtype_variant(envelope, tag as u32, tag.name(), body)
}

/// Writes the envelope's `Serialize` and `Deserialize` through [`WireTag`]: one newtype
/// variant per tag, named as the tag.
macro_rules! envelope_serde {
    ($envelope:ident; $($variant:ident),+ $(,)?) => {
        impl serde::Serialize for $envelope {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                match self {
                    $($envelope::$variant(body) => $crate::wire::serialize_variant(
                        s,
                        stringify!($envelope),
                        $crate::wire::WireTag::$variant,
                        body,
                    ),)+
                }
            }
        }

        impl<'de> serde::Deserialize<'de> for $envelope {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct Visitor;
                impl<'de> serde::de::Visitor<'de> for Visitor {
                    type Value = $envelope;
                    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                        f.write_str(concat!("enum ", stringify!($envelope)))
                    }
                    fn visit_enum<A: serde::de::EnumAccess<'de>>(
                        self,
                        data: A,
                    ) -> Result<$envelope, A::Error> {
                        use serde::de::VariantAccess as _;
                        let (tag, body) = data.variant::<$crate::wire::WireTag>()?;
                        match tag {
                            $($crate::wire::WireTag::$variant => {
                                body.newtype_variant().map($envelope::$variant)
                            })+
                        }
                    }
                }
                d.deserialize_enum(stringify!($envelope), $crate::wire::WireTag::NAMES, Visitor)
            }
        }

        impl $envelope {
            /// Its wire tag, the first byte of its encoding.
            pub fn tag(&self) -> $crate::wire::WireTag {
                match self {
                    $($envelope::$variant(_) => $crate::wire::WireTag::$variant,)+
                }
            }
        }
    };
}
pub(crate) use envelope_serde;

/// Every tag as `(variant name, value)`, in registry order (the consensus layer's last).
pub fn tags() -> Vec<(&'static str, u8)> {
    WireTag::ALL.iter().map(|t| (t.name(), *t as u8)).collect()
}

/// A variant name as a constant: `Goto` -> `GOTO`, `PathFollow` -> `PATH_FOLLOW`.
fn constant_name(variant: &str) -> String {
    let mut s = String::new();
    for (i, ch) in variant.chars().enumerate() {
        if ch.is_ascii_uppercase() && i > 0 {
            s.push('_');
        }
        s.push(ch.to_ascii_uppercase());
    }
    s
}

/// The Python module (`bindings/python/swarmrt/_tags.py`).
pub fn python_module() -> String {
    let mut out = String::from(
        "\"\"\"swarmrt radio and note envelope tags: the first byte of a postcard `RadioMsg`\n\
         (and of each `Note` of a report).\n\n\
         GENERATED from the Rust registry by swarmrt_agent::wire; do not edit\n\
         (SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-agent --test agent wire_tags rewrites it).\n\
         The tags are declared in agent/src/behaviours/mod.rs and never move.\n\"\"\"\n\n",
    );
    for (name, tag) in tags() {
        out.push_str(&format!(
            "{} = {tag}\n\"\"\"`RadioMsg::{name}`.\"\"\"\n",
            constant_name(name)
        ));
    }
    out.push_str("\nTAGS = {\n");
    for (name, tag) in tags() {
        out.push_str(&format!("    \"{name}\": {tag},\n"));
    }
    out.push_str("}\n\"\"\"Every tag by its Rust variant name.\"\"\"\n");
    out
}

/// The C header (`bindings/c/include/swarmrt_tags.h`).
pub fn c_header() -> String {
    let mut out = String::from(
        "/* swarmrt radio and note envelope tags: the first byte of a postcard RadioMsg (and of\n \
         * each Note of a report). GENERATED from the Rust registry by swarmrt_agent::wire; do\n \
         * not edit (SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-agent --test agent wire_tags\n \
         * rewrites it). The tags are declared in agent/src/behaviours/mod.rs and never move. */\n\
         #ifndef SWARMRT_TAGS_H\n#define SWARMRT_TAGS_H\n\n",
    );
    for (name, tag) in tags() {
        out.push_str(&format!(
            "/* RadioMsg::{name}. */\n#define SWARMRT_TAG_{} {tag}u\n",
            constant_name(name)
        ));
    }
    out.push_str("\n#endif /* SWARMRT_TAGS_H */\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_names_are_upper_snake_case() {
        assert_eq!(constant_name("Goto"), "GOTO");
        assert_eq!(constant_name("PathFollow"), "PATH_FOLLOW");
    }

    #[test]
    fn tags_are_distinct_and_named_by_their_variants() {
        let mut values: Vec<u8> = tags().iter().map(|t| t.1).collect();
        values.sort();
        values.dedup();
        assert_eq!(values.len(), WireTag::ALL.len());
        for t in WireTag::ALL {
            assert_eq!(WireTag::from_u64(*t as u64), Some(*t));
            assert_eq!(WireTag::from_name(t.name()), Some(*t));
        }
        assert_eq!(WireTag::Consensus as u8, CONSENSUS_TAG);
        assert_eq!(WireTag::from_u64(OPAQUE_TAG as u64), None);
    }
}
