//! Shapes shared by several spec files.

use crate::cite::Cites;
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;
use std::collections::HashSet;

/// One normative sentence of a manual, in our words, with its source.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rule {
    /// Short snake_case name, unique within its list; code and tests refer to rules by it.
    pub id: String,
    pub statement: String,
    pub cite: Cites,
}

/// A measured or stated quantity with its qualifier ("approximately") and source.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Quantity {
    pub value: f64,
    pub units: String,
    /// How exact the manual is: `exact`, `approximately`, `default`.
    pub qualifier: Qualifier,
    pub cite: Cites,
    /// For a quantity the manual gives only approximately: the values the model admits, with
    /// the reason for the band (the manuals give no tolerance, so the band is a `MODEL` reading).
    #[serde(default)]
    pub interval: Option<Interval>,
}

/// The values an approximate quantity may take, `[min, max]`, with why.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Interval {
    pub min: f64,
    pub max: f64,
    pub reason: String,
    pub cite: Cites,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Qualifier {
    Exact,
    Approximately,
    Default,
}

/// An inclusive integer range `[min, max]`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct Range {
    pub min: i64,
    pub max: i64,
}

impl Range {
    pub fn contains(&self, v: i64) -> bool {
        self.min <= v && v <= self.max
    }
}

/// Rejects two rules with the same id; `path` is the dotted path of the list.
pub fn unique_rule_ids(map: &SourceMap, path: &str, rules: &[Rule]) -> Result<(), SpecError> {
    let mut seen = HashSet::new();
    for (i, r) in rules.iter().enumerate() {
        if !is_identifier(&r.id) {
            return Err(map.error(&format!("{path}.{i}"), format!("rule id `{}` is not a snake_case identifier", r.id)));
        }
        if !seen.insert(r.id.as_str()) {
            return Err(map.error(&format!("{path}.{i}"), format!("duplicate rule id `{}`", r.id)));
        }
    }
    Ok(())
}

pub fn is_identifier(s: &str) -> bool {
    !s.is_empty()
        && s.chars().next().is_some_and(|c| c.is_ascii_lowercase())
        && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}
