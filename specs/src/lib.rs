//! # The spec directory: Turbo PMAC watchdog facts as data
//!
//! `specs/` holds every normative fact the project encodes, one YAML file per topic, each fact
//! with its citation. This module doc is the format's documentation; the types of each file's
//! module are its schema, field by field.
//!
//! | file | module | what it holds |
//! |---|---|---|
//! | `variables.yaml` | [`variables`] | I8, I40, I41 (range, units, default, meaning), the I41 lockout table and rules, the registers (Y:$25, X:$25, X:$0, X:$6, Y:$6, X:$1080, X:$1090, ...) |
//! | `watchdog.yaml` | [`facts::Watchdog`] | hardware conditions (supply and strobe minimum), counter rules, trip actions, recovery |
//! | `status.yaml` | [`status`] | all 48 bits of the `???` reply and the bootstrap reply |
//! | `checksums.yaml` | [`facts::Checksums`] | firmware and user-program checksum rules |
//! | `stop_commands.yaml` | [`facts::StopCommands`] | the 11-row stop-command table of UM p.217 |
//! | `scheduling.yaml` | [`facts::Scheduling`] | servo clock, RTI, PLC 0, background cycle |
//! | `profiles.yaml` | [`profiles`] | the readings where sources disagree, and the named profiles |
//! | `check.yaml` | [`check`] | the bounded configurations `pmacwd check` explores |
//! | `requirements.yaml` | [`requirements`] | the requirements matrix: each normative statement of the manual pages, quoted, and what encodes and checks it |
//!
//! Subdirectories (`scenarios/`, `captures/`) belong to the conformance suite and are not read
//! here; the scenario library is embedded as [`scenarios::SCENARIOS`] so that the command line
//! finds it from any folder. Any other `.yaml` file in the directory is an error, so nothing is silently ignored.
//!
//! ## Conventions
//!
//! - Every entry that states a fact has a `cite:` field: one citation or a list (see [`cite`]
//!   for the sources and the `UM p.215` syntax).
//! - Rules are `{id, statement, cite}`; ids are snake_case and unique within their list.
//! - Names (status bits, profiles) are unique; a key written twice in one mapping is an error.
//!
//! ## Strictness
//!
//! The loader rejects, with file, line and column: YAML syntax errors; unknown keys
//! (`deny_unknown_fields` everywhere); duplicate keys; missing required keys; values of the
//! wrong type; and out-of-range or inconsistent values (an I-variable range wider than the
//! variable can hold, a default outside its range, a status word without all 24 bits, two
//! bits with one name, a profile that skips a reading, two default profiles, an unknown
//! citation source, ...).
//!
//! ```
//! let spec = pmacwd_specs::Spec::embedded().expect("the shipped specs load");
//! assert_eq!(spec.variables.i_variables.i40.range.max, 65_535);
//! assert_eq!(spec.status.bit("rti_reentry"), Some((pmacwd_specs::status::WordId::X, 22)));
//! ```

pub mod check;
pub mod cite;
pub mod common;
pub mod config;
mod error;
pub mod facts;
pub mod grammar;
pub mod input;
pub mod profiles;
pub mod protocol;
pub mod requirements;
pub mod scenarios {
    //! The scenario library of `specs/scenarios/`, compiled in (see `build.rs`).
    include!(concat!(env!("OUT_DIR"), "/scenarios.rs"));
}
pub mod status;
pub mod variables;
pub mod vocab;
pub mod yaml;

pub use error::{Position, SpecError};

use std::path::{Path, PathBuf};

/// The spec files, in load order, with their embedded copies.
const FILES: [(&str, &str); 9] = [
    ("variables.yaml", include_str!("../variables.yaml")),
    ("watchdog.yaml", include_str!("../watchdog.yaml")),
    ("status.yaml", include_str!("../status.yaml")),
    ("checksums.yaml", include_str!("../checksums.yaml")),
    ("stop_commands.yaml", include_str!("../stop_commands.yaml")),
    ("scheduling.yaml", include_str!("../scheduling.yaml")),
    ("profiles.yaml", include_str!("../profiles.yaml")),
    ("check.yaml", include_str!("../check.yaml")),
    ("requirements.yaml", include_str!("../requirements.yaml")),
];

/// A loaded, validated spec directory.
#[derive(Clone, Debug)]
pub struct Spec {
    /// Where it came from (`specs/` for the embedded copy).
    pub dir: PathBuf,
    pub variables: variables::Variables,
    pub watchdog: facts::Watchdog,
    pub status: status::Status,
    pub checksums: facts::Checksums,
    pub stop_commands: facts::StopCommands,
    pub scheduling: facts::Scheduling,
    pub profiles: profiles::Profiles,
    pub check: check::Check,
    /// Positions in `check.yaml`, so later checks (host-command syntax) can point into it.
    pub check_map: yaml::SourceMap,
    /// The requirements matrix; its `spec` references are checked against the other files.
    pub requirements: requirements::Requirements,
}

impl Spec {
    /// The spec compiled into the binary: the `specs/` directory of this source tree. Parsed
    /// once per process, on first use; later calls clone it.
    pub fn embedded() -> Result<Spec, SpecError> {
        static EMBEDDED: std::sync::OnceLock<Result<Spec, SpecError>> = std::sync::OnceLock::new();
        EMBEDDED.get_or_init(|| Self::from_named_texts(Path::new("specs"), &FILES)).clone()
    }

    /// Loads spec files held in memory, as (file name, text) pairs, as if they were the files
    /// of `dir`; a file missing from `files` reads as empty. The entry point of the fuzz
    /// targets (`fuzz/`), which must not touch the disk; not part of the API.
    #[doc(hidden)]
    pub fn from_named_texts(dir: &Path, files: &[(&str, &str)]) -> Result<Spec, SpecError> {
        Self::from_texts(dir, |name| {
            Ok(files.iter().find(|(n, _)| *n == name).map(|(_, t)| t.to_string()).unwrap_or_default())
        })
    }

    /// Loads every spec file of `dir`.
    pub fn load_dir(dir: &Path) -> Result<Spec, SpecError> {
        let entries = std::fs::read_dir(dir)
            .map_err(|e| SpecError::whole_file(dir, format!("cannot read spec directory: {e}")))?;
        for entry in entries {
            let entry = entry.map_err(|e| SpecError::whole_file(dir, format!("cannot read spec directory: {e}")))?;
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().to_string();
            let is_yaml = name.ends_with(".yaml") || name.ends_with(".yml");
            if !is_yaml {
                continue;
            }
            if !FILES.iter().any(|(n, _)| *n == name) {
                let known: Vec<&str> = FILES.iter().map(|(n, _)| *n).collect();
                return Err(SpecError::whole_file(
                    &path,
                    format!("unexpected spec file (known files: {})", known.join(", ")),
                ));
            }
            // A directory, a FIFO or a dangling symlink with a spec file's name is an error
            // here, not something skipped.
            input::open_regular(&path)?;
        }
        Self::from_texts(dir, |name| input::read_text(&dir.join(name), input::SPEC_FILE_BYTES_MAX))
    }

    fn from_texts(dir: &Path, read: impl Fn(&str) -> Result<String, SpecError>) -> Result<Spec, SpecError> {
        fn load<T: serde::de::DeserializeOwned>(
            dir: &Path,
            name: &str,
            read: &impl Fn(&str) -> Result<String, SpecError>,
        ) -> Result<(T, yaml::SourceMap), SpecError> {
            let text = read(name)?;
            yaml::parse(&dir.join(name), &text)
        }
        // Each file is parsed once; its source map is kept for the requirements' references.
        let (variables, variables_map) = load::<variables::Variables>(dir, "variables.yaml", &read)?;
        variables.validate(&variables_map)?;
        let (watchdog, watchdog_map) = load::<facts::Watchdog>(dir, "watchdog.yaml", &read)?;
        watchdog.validate(&watchdog_map)?;
        let (status, status_map) = load::<status::Status>(dir, "status.yaml", &read)?;
        status.validate(&status_map)?;
        let (checksums, checksums_map) = load::<facts::Checksums>(dir, "checksums.yaml", &read)?;
        checksums.validate(&checksums_map)?;
        let (stop_commands, stop_commands_map) = load::<facts::StopCommands>(dir, "stop_commands.yaml", &read)?;
        stop_commands.validate(&stop_commands_map)?;
        let (scheduling, scheduling_map) = load::<facts::Scheduling>(dir, "scheduling.yaml", &read)?;
        scheduling.validate(&scheduling_map)?;
        let (profiles, profiles_map) = load::<profiles::Profiles>(dir, "profiles.yaml", &read)?;
        profiles.validate(&profiles_map)?;
        let (check, check_map) = load::<check::Check>(dir, "check.yaml", &read)?;
        let names: Vec<String> = profiles.profiles.keys().cloned().collect();
        check.validate(&check_map, &names, &scheduling.servo_clock_hz_range)?;
        let (requirements, m) = load::<requirements::Requirements>(dir, "requirements.yaml", &read)?;
        // In FILES' order, every file but requirements.yaml itself.
        let others = [
            ("variables.yaml", &variables_map),
            ("watchdog.yaml", &watchdog_map),
            ("status.yaml", &status_map),
            ("checksums.yaml", &checksums_map),
            ("stop_commands.yaml", &stop_commands_map),
            ("scheduling.yaml", &scheduling_map),
            ("profiles.yaml", &profiles_map),
            ("check.yaml", &check_map),
        ];
        debug_assert!(others
            .iter()
            .map(|(n, _)| *n)
            .eq(FILES.iter().map(|(n, _)| *n).filter(|n| *n != "requirements.yaml")));
        requirements.validate(&m, &others)?;
        Ok(Spec {
            dir: dir.to_path_buf(),
            variables,
            watchdog,
            status,
            checksums,
            stop_commands,
            scheduling,
            profiles,
            check,
            check_map,
            requirements,
        })
    }

    /// The file names a spec directory holds.
    pub fn file_names() -> impl Iterator<Item = &'static str> {
        FILES.iter().map(|(n, _)| *n)
    }
}
