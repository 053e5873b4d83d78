//! `requirements.yaml`: the requirements matrix. Each normative statement of the manual pages
//! the project relies on, quoted, with its page, and what encodes and checks it.
//!
//! ```yaml
//! statements:
//!   - id: counter_reset_each_background_cycle      # snake_case, unique
//!     source: UM p.215                             # one manual page (UM, SRM, PMAC-UM, PMAC-SRM)
//!     quote: At the end of each background cycle, the CPU resets the counter value ...
//!     # or, for a page read beyond the seed excerpts, the statement in this project's words:
//!     # summary: Y:$25 is reloaded at the end of every background cycle ...
//!     encoded_by:                                  # what encodes it, what checks it
//!       - spec: watchdog.yaml#rules.counter_reset  # a key of a spec file; list items by id, name, command or number
//!       - property: a background cycle reloads the counter from I40   # model property or monitor
//!       - scenario: a-reset-starts-x25-over-at-the-reset-value       # file stem in scenarios/
//!       - test: model/tests/semantics.rs::with_i40_zero_each_profile_reloads_its_own_reset_value
//!     status: data_only        # optional: data_only (only YAML data, no rule reads it),
//!                              # by_definition (its checks hold by construction) or missing
//!     deviation: {reason: ...} # optional: deliberately not encoded, and why
//!     note: ...                # optional free text
//! ```
//!
//! Each statement falls into exactly one category ([`Category`]):
//!
//! - **checked**: `encoded_by` names at least one property, scenario or test, and neither a
//!   status nor a deviation is given;
//! - **by definition**: `status: by_definition`, with the checks that name it and a `note`
//!   saying why they cannot fail (the model defines the observed value from the state the
//!   property assumes: the LED, FEFCO/, the relay and the outputs are `tripped` itself);
//! - **data only**: `status: data_only`, and `encoded_by` names only `spec` keys (at least one);
//! - **missing**: `status: missing`, and `encoded_by` is empty;
//! - **deviation**: a `deviation` with its reason, and no status.
//!
//! The loader checks the shape, the citations and that every `spec` reference names a key that
//! exists. Properties, scenarios and tests live in other crates: `conformance/tests/requirements.rs`
//! resolves them.

use crate::cite::{Cites, Source};
use crate::common::is_identifier;
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;
use std::collections::HashSet;
use std::fmt;

/// `requirements.yaml`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Requirements {
    pub statements: Vec<Statement>,
}

/// One normative sentence (or clause) of a manual page, quoted or summarized.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Statement {
    pub id: String,
    /// The page it is on: exactly one manual citation with a page.
    pub source: Cites,
    /// The manual's words, verbatim (elisions marked `...`): for the seed excerpts the project
    /// was created from.
    #[serde(default)]
    pub quote: Option<String>,
    /// The statement in this project's words, for a page read elsewhere (the manuals' pages
    /// are cited, not copied): what it requires, precisely enough to check against the page.
    #[serde(default)]
    pub summary: Option<String>,
    #[serde(default)]
    pub encoded_by: Vec<Reference>,
    #[serde(default)]
    pub status: Option<Status>,
    #[serde(default)]
    pub deviation: Option<Deviation>,
    #[serde(default)]
    pub note: Option<String>,
}

/// What encodes or checks a statement: a one-key mapping, `{property: NAME}`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reference {
    /// `FILE.yaml#dotted.path`: a key of a spec file; a list item is named by its `id`,
    /// `name` or `command` (or its index).
    Spec(String),
    /// The `name` of a model property (`STATE_PROPERTIES`) or monitor (`MONITORS`).
    Property(String),
    /// The file stem of a scenario in `specs/scenarios/`.
    Scenario(String),
    /// `PATH::function`: a test function, PATH relative to the workspace root.
    Test(String),
}

impl<'de> Deserialize<'de> for Reference {
    /// A visitor, so that a second key or an unknown one is reported where it is written.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Reference;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(
                    "a reference: one of `spec: FILE#path`, `property: NAME`, `scenario: STEM`, `test: PATH::fn`",
                )
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Reference, A::Error> {
                use serde::de::Error as _;
                let Some(key) = map.next_key::<String>()? else {
                    return Err(A::Error::custom(
                        "an empty reference: give one of `spec`, `property`, `scenario`, `test`",
                    ));
                };
                let value: String = map.next_value()?;
                let r = match key.as_str() {
                    "spec" => Reference::Spec(value),
                    "property" => Reference::Property(value),
                    "scenario" => Reference::Scenario(value),
                    "test" => Reference::Test(value),
                    other => {
                        return Err(A::Error::custom(format!(
                            "unknown reference kind `{other}` (kinds: spec, property, scenario, test)"
                        )))
                    }
                };
                if let Some(second) = map.next_key::<String>()? {
                    return Err(A::Error::custom(format!(
                        "a second key `{second}`: a reference has exactly one of the keys `spec`, `property`, `scenario`, `test`"
                    )));
                }
                Ok(r)
            }
        }
        d.deserialize_map(Visitor)
    }
}

impl Reference {
    pub fn kind(&self) -> &'static str {
        match self {
            Reference::Spec(_) => "spec",
            Reference::Property(_) => "property",
            Reference::Scenario(_) => "scenario",
            Reference::Test(_) => "test",
        }
    }

    pub fn target(&self) -> &str {
        match self {
            Reference::Spec(s) | Reference::Property(s) | Reference::Scenario(s) | Reference::Test(s) => s,
        }
    }

    /// A property, scenario or test: something that fails when the statement is broken.
    pub fn is_check(&self) -> bool {
        !matches!(self, Reference::Spec(_))
    }
}

impl fmt::Display for Reference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.kind(), self.target())
    }
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Named by properties or scenarios that hold by construction of the model (and the core's
    /// bridge), so they cannot fail on their own.
    ByDefinition,
    /// Held as YAML data that no rule of the model or the core reads.
    DataOnly,
    /// Not encoded anywhere yet.
    Missing,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Deviation {
    pub reason: String,
}

/// The coverage category of a statement (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Category {
    Checked,
    ByDefinition,
    DataOnly,
    Missing,
    Deviation,
}

impl Category {
    pub const ALL: [Category; 5] =
        [Category::Checked, Category::ByDefinition, Category::DataOnly, Category::Missing, Category::Deviation];

    pub fn label(self) -> &'static str {
        match self {
            Category::Checked => "encoded and checked",
            Category::ByDefinition => "by definition",
            Category::DataOnly => "data only",
            Category::Missing => "missing",
            Category::Deviation => "deviation",
        }
    }

    /// The snake_case key used in JSON output.
    pub fn key(self) -> &'static str {
        match self {
            Category::Checked => "checked",
            Category::ByDefinition => "by_definition",
            Category::DataOnly => "data_only",
            Category::Missing => "missing",
            Category::Deviation => "deviation",
        }
    }
}

impl Statement {
    /// The statement as the matrix prints it: the quote in double quotes, or the summary
    /// marked as one.
    pub fn text(&self) -> String {
        match (&self.quote, &self.summary) {
            (Some(q), _) => format!("\"{}\"", one_line(q)),
            (None, Some(s)) => format!("(summary) {}", one_line(s)),
            (None, None) => String::new(),
        }
    }

    /// The category; the loader has made sure exactly one applies.
    pub fn category(&self) -> Category {
        match (&self.deviation, self.status) {
            (Some(_), _) => Category::Deviation,
            (None, Some(Status::ByDefinition)) => Category::ByDefinition,
            (None, Some(Status::DataOnly)) => Category::DataOnly,
            (None, Some(Status::Missing)) => Category::Missing,
            (None, None) => Category::Checked,
        }
    }

    /// The page, as written: `UM p.215`.
    pub fn page(&self) -> String {
        let c = &self.source.0[0];
        format!("{} p.{}", c.source.token(), c.page.as_deref().unwrap_or(""))
    }

    /// Each single page the source covers: `SRM p.289-290` gives `SRM p.289` and `SRM p.290`.
    pub fn pages(&self) -> Vec<String> {
        let c = &self.source.0[0];
        pages_of(c.source.token(), c.page.as_deref().unwrap_or(""))
    }
}

/// The single pages of a page or range: `("SRM", "289-290")` gives `SRM p.289`, `SRM p.290`.
pub fn pages_of(token: &str, page: &str) -> Vec<String> {
    if let Some((a, b)) = page.split_once('-') {
        if let (Ok(a), Ok(b)) = (a.parse::<u32>(), b.parse::<u32>()) {
            if a <= b && b - a < 100 {
                return (a..=b).map(|p| format!("{token} p.{p}")).collect();
            }
        }
    }
    vec![format!("{token} p.{page}")]
}

impl Requirements {
    /// The statements of each category.
    pub fn count(&self, category: Category) -> usize {
        self.statements.iter().filter(|s| s.category() == category).count()
    }

    /// Checks the shape of every statement, and that every `spec` reference resolves in the
    /// spec file it names: `spec_files` are the other files' names with the source maps their
    /// one parse built.
    pub(crate) fn validate(&self, map: &SourceMap, spec_files: &[(&str, &SourceMap)]) -> Result<(), SpecError> {
        let mut ids = HashSet::new();
        for (i, s) in self.statements.iter().enumerate() {
            let at = format!("statements.{i}");
            if !is_identifier(&s.id) {
                return Err(
                    map.error(&format!("{at}.id"), format!("statement id `{}` is not a snake_case identifier", s.id))
                );
            }
            if !ids.insert(s.id.as_str()) {
                return Err(map.error(&format!("{at}.id"), format!("duplicate statement id `{}`", s.id)));
            }
            let [c] = s.source.0.as_slice() else {
                return Err(map.error(&format!("{at}.source"), "a statement has exactly one source page"));
            };
            if !matches!(c.source, Source::Um | Source::Srm | Source::PmacUm | Source::PmacSrm) || c.page.is_none() {
                return Err(map.error(
                    &format!("{at}.source"),
                    format!("`{}`: a statement's source is a manual page (UM, SRM, PMAC-UM, PMAC-SRM p.N)", s.source),
                ));
            }
            match (&s.quote, &s.summary) {
                (Some(q), None) if q.trim().is_empty() => {
                    return Err(map.error(&format!("{at}.quote"), "the quote is empty"));
                }
                (None, Some(q)) if q.trim().is_empty() => {
                    return Err(map.error(&format!("{at}.summary"), "the summary is empty"));
                }
                (Some(_), None) | (None, Some(_)) => {}
                (Some(_), Some(_)) => {
                    return Err(map.error(&at, format!("statement `{}`: give a quote or a summary, not both", s.id)));
                }
                (None, None) => {
                    return Err(map.error(
                        &at,
                        format!("statement `{}`: give the `quote` (the manual's words) or a `summary` (in ours)", s.id),
                    ));
                }
            }
            let checks = s.encoded_by.iter().filter(|r| r.is_check()).count();
            let shape = match (&s.deviation, s.status) {
                (Some(_), Some(_)) => Err("give either a deviation or a status, not both"),
                (Some(d), None) if d.reason.trim().is_empty() => Err("a deviation needs its reason"),
                (Some(_), None) => Ok(()),
                (None, Some(Status::DataOnly)) if s.encoded_by.is_empty() || checks > 0 => Err(
                    "`status: data_only` lists the spec keys that hold the statement, and no property, scenario or test (with one, drop the status)",
                ),
                (None, Some(Status::ByDefinition)) if checks == 0 || s.note.is_none() => Err(
                    "`status: by_definition` names the checks that hold by construction and a `note` saying why",
                ),
                (None, Some(Status::Missing)) if !s.encoded_by.is_empty() => {
                    Err("`status: missing` with references: drop the references, or the status")
                }
                (None, Some(_)) => Ok(()),
                (None, None) if checks == 0 => Err(
                    "no property, scenario or test checks this statement: add one to `encoded_by`, or give `status: data_only`, `status: missing` or a `deviation` with its reason",
                ),
                (None, None) => Ok(()),
            };
            if let Err(message) = shape {
                return Err(map.error(&at, format!("statement `{}`: {message}", s.id)));
            }
            for (j, r) in s.encoded_by.iter().enumerate() {
                let at = format!("{at}.encoded_by.{j}");
                if r.target().trim().is_empty() {
                    return Err(map.error(&at, format!("an empty `{}` reference", r.kind())));
                }
                let Reference::Spec(target) = r else { continue };
                let Some((file, path)) = target.split_once('#') else {
                    return Err(map.error(&at, format!("spec reference `{target}`: write FILE.yaml#dotted.path")));
                };
                let Some((_, file_map)) = spec_files.iter().find(|(n, _)| *n == file) else {
                    let names: Vec<&str> = spec_files.iter().map(|(n, _)| *n).collect();
                    return Err(map.error(
                        &at,
                        format!("spec reference `{target}`: no spec file `{file}` (files: {})", names.join(", ")),
                    ));
                };
                if !file_map.has_path(path) {
                    return Err(map.error(&at, format!("spec reference `{target}`: `{path}` is not a key of {file}")));
                }
            }
        }
        Ok(())
    }
}

/// `text` on one line: runs of whitespace (YAML's folded line breaks) as one space.
pub fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}
