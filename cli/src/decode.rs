//! `pmacwd decode`: a `???` reply explained bit by bit.

use crate::common::{json_document_of_text, json_version, load_spec, Format};
use std::path::PathBuf;
use std::process::ExitCode;

pub fn decode_reply(reply: &str, format: Format, specs: Option<PathBuf>) -> ExitCode {
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    match pmacwd_capture::decode::explain(&spec, reply) {
        Ok(d) if format == Format::Json => {
            println!("{}", json_document_of_text("decode", json_version::DECODE, &pmacwd_capture::decode::to_json(&d)));
            ExitCode::SUCCESS
        }
        Ok(d) => {
            print!("{}", pmacwd_capture::decode::to_text(&d));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        }
    }
}
