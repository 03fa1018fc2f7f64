//! What a config value must be beyond its type, as one [`Key`] row per key, and the checks
//! that read them. Each section's rows live beside its struct (`consensus::KEYS`,
//! `faults::KEYS`, a behaviour's `Params::KEYS`), its validator checks against those rows,
//! and the reference (`reference.rs`, `docs/config.md`) renders the same rows: the numbers a
//! user reads are the numbers checked. Depends on nothing of the config itself.

use crate::error::KeyError;

/// One end of a range: a number, or an expression of other keys the validator computes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lim {
    /// A constant.
    V(f64),
    /// Depends on other keys, e.g. `"2 * robots.radius"`.
    Of(&'static str),
}

/// What a value must be, beyond its type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bounds {
    /// Anything of its type (an enum's names are listed from the schema).
    Any,
    /// A finite number.
    Finite,
    /// A number in `[lo, hi]`, ends included; for an array, every element.
    Range(Lim, Lim),
    /// A rule checked in code, in words.
    Rule(&'static str),
}

/// One key of the reference: the dotted path (`[i]` for an element of an array of tables),
/// its bounds, unit and meaning. Type and default come from the schema.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Key {
    /// Dotted path, e.g. `robots.lidar.rays` or `map.circles[i].r`.
    pub path: &'static str,
    /// What the validator accepts.
    pub bounds: Bounds,
    /// A further condition, in words (shown after the bounds).
    pub also: &'static str,
    /// SI unit (or `ticks`, `deg`, ...); empty when it has none.
    pub unit: &'static str,
    /// One line of meaning.
    pub meaning: &'static str,
    /// The type when the schema's example cannot show it (an id or a name, an empty list).
    pub ty: &'static str,
    /// The default of a key serde leaves out of the resolved config while it has it (an
    /// empty list, `false`, an unset option): `"unset"` or the TOML value.
    pub absent: &'static str,
}

/// A key with `bounds`, `unit` and `meaning`.
pub const fn k(
    path: &'static str,
    bounds: Bounds,
    unit: &'static str,
    meaning: &'static str,
) -> Key {
    Key {
        path,
        bounds,
        also: "",
        unit,
        meaning,
        ty: "",
        absent: "unset",
    }
}

/// The rows of several tables, in order, as one table of `N` rows (a section's rows are its
/// own; the reference lists them all).
pub const fn concat<const N: usize>(tables: &[&[Key]]) -> [Key; N] {
    let mut out = [k("", Bounds::Any, "", ""); N];
    let (mut n, mut t) = (0, 0);
    while t < tables.len() {
        let mut i = 0;
        while i < tables[t].len() {
            out[n] = tables[t][i];
            n += 1;
            i += 1;
        }
        t += 1;
    }
    assert!(n == N, "concat: N is not the number of rows");
    out
}

/// `[lo, hi]` with constant ends.
pub const fn r(lo: f64, hi: f64) -> Bounds {
    Bounds::Range(Lim::V(lo), Lim::V(hi))
}

impl Key {
    /// With a further condition.
    pub const fn also(mut self, also: &'static str) -> Key {
        self.also = also;
        self
    }

    /// With its type spelled out.
    pub const fn ty(mut self, ty: &'static str) -> Key {
        self.ty = ty;
        self
    }

    /// With the default serde leaves out of the resolved config (a TOML value).
    pub const fn absent(mut self, value: &'static str) -> Key {
        self.absent = value;
        self
    }

    /// The constant lower end of this row's range.
    pub fn lo(&self) -> f64 {
        lo(std::slice::from_ref(self), self.path)
    }

    /// The constant upper end of this row's range.
    pub fn hi(&self) -> f64 {
        hi(std::slice::from_ref(self), self.path)
    }

    /// `v` within this row's range, a number.
    pub fn check(&self, v: f64) -> Result<(), KeyError> {
        self.check_at(self.path, v)
    }

    /// `v` within this row's range, an integer.
    pub fn check_int(&self, v: u64) -> Result<(), KeyError> {
        self.check_int_at(self.path, v)
    }

    /// [`Key::check`] at `key`, this row's path with its indices (`faults.kill[2].tick`).
    pub fn check_at(&self, key: &str, v: f64) -> Result<(), KeyError> {
        check_f(std::slice::from_ref(self), key, v)
    }

    /// [`Key::check_int`] at `key`, this row's path with its indices.
    pub fn check_int_at(&self, key: &str, v: u64) -> Result<(), KeyError> {
        check_u(std::slice::from_ref(self), key, v)
    }
}

/// `map.circles[3].x` -> `map.circles[i].x`; `map.bounds[2]` -> `map.bounds` (the element of
/// an array of values has the array's row).
pub fn pattern(key: &str) -> String {
    let mut out = String::with_capacity(key.len());
    let mut chars = key.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '[' && chars.peek().is_some_and(char::is_ascii_digit) {
            while chars.next().is_some_and(|c| c != ']') {}
            out.push_str("[i]");
        } else {
            out.push(c);
        }
    }
    while out.ends_with("[i]") {
        out.truncate(out.len() - 3);
    }
    out
}

/// The row of `key` (indices allowed) in `table`. Panics when there is none: a validator that
/// checks a key the reference does not list is a bug the tests catch.
pub fn find<'a>(table: &'a [Key], key: &str) -> &'a Key {
    let p = pattern(key);
    table
        .iter()
        .find(|k| k.path == p)
        .unwrap_or_else(|| panic!("the config reference has no row for `{p}`"))
}

fn ends(table: &[Key], key: &str) -> (Lim, Lim) {
    match find(table, key).bounds {
        Bounds::Range(lo, hi) => (lo, hi),
        b => panic!("the config reference gives `{key}` no range but {b:?}"),
    }
}

/// The constant lower end of `key`'s range.
pub fn lo(table: &[Key], key: &str) -> f64 {
    match ends(table, key).0 {
        Lim::V(v) => v,
        Lim::Of(e) => panic!("the lower end of `{key}` is {e}, not a constant"),
    }
}

/// The constant upper end of `key`'s range.
pub fn hi(table: &[Key], key: &str) -> f64 {
    match ends(table, key).1 {
        Lim::V(v) => v,
        Lim::Of(e) => panic!("the upper end of `{key}` is {e}, not a constant"),
    }
}

/// `v` within the range `table` gives `key` (a number).
pub fn check_f(table: &[Key], key: &str, v: f64) -> Result<(), KeyError> {
    range_f(key, v, lo(table, key), hi(table, key))
}

/// `v` within the range `table` gives `key` (an integer).
pub fn check_u(table: &[Key], key: &str, v: u64) -> Result<(), KeyError> {
    range_u64(key, v, lo(table, key) as u64, hi(table, key) as u64)
}

/// `Ok` when `ok`, else an error at `key` saying what was `expected`.
pub fn check(ok: bool, key: &str, expected: &str) -> Result<(), KeyError> {
    if ok {
        Ok(())
    } else {
        Err((key.to_string(), format!("expected {expected}")))
    }
}

/// `v` must be finite.
pub fn finite(key: &str, v: f64) -> Result<(), KeyError> {
    check(
        v.is_finite(),
        key,
        &format!("a finite number, got {}", short(v)),
    )
}

/// `v` must be finite and in `[lo, hi]`.
pub fn range_f(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), KeyError> {
    check(
        v.is_finite() && v >= lo && v <= hi,
        key,
        &format!("a number in [{lo}, {hi}], got {}", short(v)),
    )
}

/// `v` for an error message: `-1e308`, not its 309 digits.
pub fn short(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// `v` must be in `[lo, hi]`.
pub fn range_u64(key: &str, v: u64, lo: u64, hi: u64) -> Result<(), KeyError> {
    check(
        v >= lo && v <= hi,
        key,
        &format!("an integer in [{lo}, {hi}], got {v}"),
    )
}
