//! `docs/config.md` is exactly what `swarmrt_scenario::reference` renders from the key tables
//! and the serde schemas, and the tables hold exactly the keys the schemas accept: a key added,
//! removed or re-bounded without regenerating the reference fails here.
//! `SWARMRT_UPDATE_DOCS=1 cargo test -p swarmrt-agent --test agent config_reference` rewrites it.

use std::collections::BTreeSet;
use std::path::PathBuf;

use swarmrt_agent::registry::BEHAVIOURS;
use swarmrt_scenario::reference::{self, BehaviourDoc, Default, Schema};

const REGENERATE: &str =
    "SWARMRT_UPDATE_DOCS=1 cargo test -p swarmrt-agent --test agent config_reference";

fn behaviours() -> Vec<BehaviourDoc> {
    BEHAVIOURS
        .iter()
        .map(|p| BehaviourDoc {
            kind: p.kind(),
            schema: p.reference(),
        })
        .collect()
}

fn schemas() -> Vec<(String, Schema)> {
    let mut all = vec![("core".to_string(), Schema::core())];
    all.extend(
        BEHAVIOURS
            .iter()
            .map(|p| (format!("behaviour {}", p.kind()), p.reference())),
    );
    all
}

#[test]
fn docs_config_md_is_generated_from_the_key_tables() {
    let want = reference::render(&Schema::core(), &behaviours());
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/config.md");
    if std::env::var_os("SWARMRT_UPDATE_DOCS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        have == want,
        "docs/config.md is not what swarmrt_scenario::reference renders; regenerate it: {REGENERATE}"
    );
}

/// Every key serde accepts has a row, and every row is a key serde accepts: each table of the
/// example lists every field its struct has (serde names them when it refuses an unknown one),
/// and the example's leaves are the table's rows.
#[test]
fn every_key_the_schema_accepts_has_a_row_and_back() {
    for (name, schema) in schemas() {
        let leaves: Vec<String> = schema.leaves().into_iter().map(|(k, _)| k).collect();
        for table in schema.tables() {
            if schema.open.contains(&table.as_str()) {
                continue;
            }
            let accepted = schema
                .accepted(&table)
                .unwrap_or_else(|| panic!("{name}: `{table}` accepts any key"));
            let prefix = if table.is_empty() {
                String::new()
            } else {
                format!("{table}.")
            };
            let written: BTreeSet<String> = leaves
                .iter()
                .chain(schema.tables().iter())
                .filter_map(|k| k.strip_prefix(&prefix))
                .filter(|rest| !rest.is_empty() && !rest.contains('.'))
                .map(|rest| rest.trim_end_matches("[i]").to_string())
                .collect();
            assert_eq!(
                accepted, written,
                "{name}: the keys serde accepts in `{table}` (left) are not the ones the example \
                 writes (right); add the new key to the example and a row to the table, then {REGENERATE}"
            );
        }
        let rows: BTreeSet<&str> = schema.keys.iter().map(|k| k.path).collect();
        let keys: BTreeSet<&str> = leaves.iter().map(String::as_str).collect();
        assert_eq!(
            rows, keys,
            "{name}: the table's rows (left) are not the schema's keys (right)"
        );
        assert_eq!(rows.len(), schema.keys.len(), "{name}: a key has two rows");
    }
}

/// A key left out of the resolved config while it has its default declares that default
/// (`Key::absent`): writing it must leave the key out again, so it is the default. Required
/// keys are refused as missing when left out.
#[test]
fn declared_defaults_are_the_ones_serde_fills_in() {
    for (name, schema) in schemas() {
        for key in schema.keys {
            let (own, _) = schema.default_of(key.path);
            if own != Default::Absent {
                assert_eq!(
                    key.absent, "unset",
                    "{name}: `{}` has a default from the code",
                    key.path
                );
                continue;
            }
            if key.absent == "unset" {
                continue;
            }
            let value: toml::Value = toml::from_str::<toml::Table>(&format!("v = {}", key.absent))
                .unwrap_or_else(|e| panic!("{name}: `{}`: {e}", key.path))
                .remove("v")
                .unwrap();
            let mut full = schema.full.clone();
            set(&mut full, key.path, value);
            let resolved = (schema.round_trip)(&full).unwrap();
            assert!(
                get(&resolved, key.path).is_none(),
                "{name}: `{}` = {} is written out, so it is not the default",
                key.path,
                key.absent
            );
        }
    }
}

fn set(t: &mut toml::Table, path: &str, v: toml::Value) {
    let (parent, last) = path.rsplit_once('.').unwrap();
    let mut cur = t;
    for part in parent.split('.') {
        let next = match part.strip_suffix("[i]") {
            Some(a) => cur
                .get_mut(a)
                .unwrap()
                .as_array_mut()
                .unwrap()
                .first_mut()
                .unwrap(),
            None => cur.get_mut(part).unwrap(),
        };
        cur = next.as_table_mut().unwrap();
    }
    cur.insert(last.to_string(), v);
}

fn get<'a>(t: &'a toml::Table, path: &str) -> Option<&'a toml::Value> {
    let mut cur: Option<&toml::Value> = None;
    let mut table = Some(t);
    for part in path.split('.') {
        let next = match part.strip_suffix("[i]") {
            Some(a) => table?.get(a)?.as_array()?.first(),
            None => table?.get(part),
        };
        cur = next;
        table = next.and_then(toml::Value::as_table);
    }
    cur
}

/// The validator reads its bounds from the table: every row it looks up exists (a lookup of a
/// missing row would panic mid-validation), exercised by a config that sets most keys.
#[test]
fn the_validator_finds_its_rows() {
    let mut full: toml::Table = toml::from_str(reference::FULL).unwrap();
    // One start layout, not three at once.
    let start = full["robots"]["start"].as_table().cloned().unwrap();
    let mut grid = start.clone();
    for k in ["groups", "group_sizes", "path", "scatter"] {
        grid.remove(k);
    }
    full.get_mut("robots")
        .unwrap()
        .as_table_mut()
        .unwrap()
        .insert("start".into(), grid.into());
    let propose: toml::Value = toml::from_str::<toml::Table>(
        "v = [{ tick = 5, goal = [5.0, 5.0] }, { tick = 6, speed = 0.5 }]",
    )
    .unwrap()
    .remove("v")
    .unwrap();
    full.get_mut("consensus")
        .unwrap()
        .as_table_mut()
        .unwrap()
        .insert("propose".into(), propose);
    let text = toml::to_string(&full).unwrap();
    swarmrt_scenario::Config::from_toml_str("full.toml", &text, &[]).unwrap();
}
