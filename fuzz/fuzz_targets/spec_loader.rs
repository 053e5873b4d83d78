//! The strict spec loader on one mutated file at a time.
//!
//! Input: the first byte chooses which of the 9 spec files is replaced (byte % 9, in load
//! order); the rest is that file's text. The other 8 are the shipped `specs/*.yaml`, so every
//! check of the loader, cross-file ones included, is reachable.
//!
//! Invariants:
//! - the loader never panics;
//! - an error names a spec file of the directory, with a 1-based position inside that file;
//! - a spec it accepts is usable: every configuration of `check.yaml` resolves under every
//!   profile (`ModelConfig::from_spec`, what `check`, `run`, `serve` do next) without a panic,
//!   and a refusal there names a spec file too.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_fuzz::{check_error, yaml_lines};
use pmacwd_specs::config::{ModelConfig, StatusLayout};
use pmacwd_specs::Spec;
use std::path::Path;

/// The spec files in load order (as `Spec::file_names()` lists them), shipped texts.
const SHIPPED: [(&str, &str); 9] = [
    ("variables.yaml", include_str!("../../specs/variables.yaml")),
    ("watchdog.yaml", include_str!("../../specs/watchdog.yaml")),
    ("status.yaml", include_str!("../../specs/status.yaml")),
    ("checksums.yaml", include_str!("../../specs/checksums.yaml")),
    ("stop_commands.yaml", include_str!("../../specs/stop_commands.yaml")),
    ("scheduling.yaml", include_str!("../../specs/scheduling.yaml")),
    ("profiles.yaml", include_str!("../../specs/profiles.yaml")),
    ("check.yaml", include_str!("../../specs/check.yaml")),
    ("requirements.yaml", include_str!("../../specs/requirements.yaml")),
];

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else { return };
    let Ok(text) = std::str::from_utf8(rest) else { return };
    let mut files = SHIPPED;
    files[usize::from(which) % files.len()].1 = text;
    let dir = Path::new("specs");
    // The error names one of the 9 files and points inside that file's text.
    let check = |e: &pmacwd_specs::SpecError| {
        let Some(&(_, t)) = files.iter().find(|(n, _)| e.file == dir.join(n)) else {
            panic!("an error that names no spec file: {e:?}");
        };
        check_error(e, &e.file, yaml_lines(t));
    };
    match Spec::from_named_texts(dir, &files) {
        Err(e) => check(&e),
        Ok(spec) => {
            if let Err(e) = StatusLayout::of(&spec) {
                check(&e);
            }
            for profile in spec.profiles.all() {
                for name in spec.check.configurations.keys() {
                    if let Err(e) = ModelConfig::from_spec(&spec, name, &profile) {
                        check(&e);
                    }
                }
            }
        }
    }
});
