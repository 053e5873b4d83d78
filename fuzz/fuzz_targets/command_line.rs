//! The `pmacwd` command line: the clap grammar of `cli/src/main.rs` (taken from its source by
//! `fuzz/build.rs`), on arbitrary argument lists.
//!
//! Input: the arguments after `pmacwd`, separated by NUL bytes (any bytes: an argument need not
//! be UTF-8).
//!
//! Invariants:
//! - the grammar passes clap's own consistency checks (`Command::debug_assert`);
//! - parsing never panics, and an error renders a message;
//! - every refusal exits 2, the documented code for unusable input, except `--help` and
//!   `--version`, which exit 0 (`pmacwd` calls `Cli::parse`, which exits with this code);
//! - an accepted argument list also parses through the untyped `clap::Command`, to the same
//!   subcommand.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;

#[allow(dead_code)]
mod grammar {
    include!(concat!(env!("OUT_DIR"), "/cli_grammar.rs"));

    pub fn command() -> clap::Command {
        <Cli as clap::CommandFactory>::command()
    }

    pub fn parse(args: &[std::ffi::OsString]) -> Result<(), clap::Error> {
        <Cli as clap::Parser>::try_parse_from(args).map(|_| ())
    }

    pub fn from_matches(m: &clap::ArgMatches) -> Result<(), clap::Error> {
        <Cli as clap::FromArgMatches>::from_arg_matches(m).map(|_| ())
    }
}

fuzz_target!(init: { grammar::command().debug_assert(); }, |data: &[u8]| {
    let mut args = vec![OsString::from("pmacwd")];
    if !data.is_empty() {
        args.extend(data.split(|&b| b == 0).map(|a| OsString::from_vec(a.to_vec())));
    }
    match grammar::parse(&args) {
        Ok(()) => {
            let m = grammar::command().try_get_matches_from(&args).expect("the typed parse accepted it");
            assert!(m.subcommand_name().is_some(), "accepted without a subcommand");
            grammar::from_matches(&m).expect("the matches convert");
        }
        Err(e) => {
            use clap::error::ErrorKind::*;
            let rendered = e.render().to_string();
            assert!(!rendered.trim().is_empty(), "an error without a message: {:?}", e.kind());
            let code = if matches!(e.kind(), DisplayHelp | DisplayVersion) { 0 } else { 2 };
            assert_eq!(e.exit_code(), code, "{:?} exits {}: {rendered}", e.kind(), e.exit_code());
        }
    }
});
