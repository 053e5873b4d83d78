//! The emulator's control interface: what a test bench does to a card that a host cannot.
//!
//! One command per line over TCP (`pmacwd serve --control ADDR`, default 127.0.0.1:1026); every
//! line gets one reply line: `ok`, `ok ` and the trace step it caused (JSON, the vocabulary of
//! `docs/trace-format.md`), `ok ` and the state, or `error: ` and why. The commands:
//!
//! ```text
//! load [motors=M] [plc0_units=P] [background_units=B]   change the CPU load (the rest stays)
//! motors M | plc0 P | background B                       one part of the load
//! starve                                                 PLC 0 takes every CPU unit the servo leaves (the background starves)
//! supply MV                                              logic supply in millivolts (trips below 4750)
//! init                                                   INIT/ pulse (UM p.215: undoes a trip)
//! power [dpram_fault] [flash_fault] [bootstrap]          power cycle, with what the reset-time checks find
//! checksum firmware|user_program                         corrupt memory the background checksum will find
//! clear_rti_reentry                                      the host writes 0 to bit 22 of X:$000006
//! step N                                                 virtual time: N servo cycles, background whenever possible
//! servo N                                                virtual time: N servo cycles, no background
//! state                                                  tripped, counter, minimum, status words, cycles, load
//! home-flag M AT|none                                    motor M's home flag triggers at AT counts (as motor M's position reads now); none: no flag
//! following-error M COUNTS                               motor M's following error reads COUNTS (0: none)
//! limit M plus|minus on|off                              motor M's limit switch at that end of travel hit or clear
//! help                                                   this list
//! ```

use pmacwd_specs::check::{ChecksumTarget, ResetEvent, ResetKind};
use std::io::{self, BufRead, Read};

/// A control line (its newline included) is at most this long; a longer one closes its
/// connection with an error line, on the emulator's control port and on the proxy's. The
/// longest command is `power dpram_fault flash_fault bootstrap` (39 bytes) and a reply is a
/// few hundred bytes (`help`), so 1,024 leaves room for spacing and future commands while a
/// client that never sends a newline holds at most a kilobyte.
pub const CONTROL_LINE_BYTES_MAX: usize = 1024;

/// Reads one line into `line` (cleared first), newline included, of at most `bytes_max`
/// bytes: `Ok(true)` for a line (or the bytes before the end of the stream), `Ok(false)` at
/// the end of the stream, and an error of kind `InvalidData` for a longer line, after which
/// the stream has no next line to find.
pub fn read_line_max(reader: &mut impl BufRead, line: &mut Vec<u8>, bytes_max: usize) -> io::Result<bool> {
    line.clear();
    let limit = u64::try_from(bytes_max).unwrap_or(u64::MAX);
    let n = reader.by_ref().take(limit).read_until(b'\n', line)?;
    if n == 0 {
        return Ok(false);
    }
    if line.last() != Some(&b'\n') && n == bytes_max {
        return Err(io::Error::new(io::ErrorKind::InvalidData, format!("a control line is at most {bytes_max} bytes")));
    }
    Ok(true)
}

/// One control command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    Load {
        motors: Option<u8>,
        plc0_units: Option<u16>,
        background_units: Option<u16>,
    },
    /// PLC 0 takes every CPU unit the servo leaves in each RTI period.
    Starve,
    Supply {
        millivolts: u32,
    },
    Reset(ResetEvent),
    ChecksumFault(ChecksumTarget),
    ClearRtiReentry,
    Step {
        cycles: u32,
    },
    Servo {
        cycles: u32,
    },
    State,
    /// Where motor `motor`'s home flag triggers, counts as its position reads now; `None`: no flag.
    HomeFlag {
        motor: u8,
        at: Option<i64>,
    },
    /// Motor `motor`'s limit switch at the plus (or minus) end hit (`on`) or clear.
    Limit {
        motor: u8,
        plus: bool,
        on: bool,
    },
    /// A following error on motor `motor`, counts.
    FollowingError {
        motor: u8,
        counts: i64,
    },
    Help,
}

pub const HELP: &str = "commands: load [motors=M] [plc0_units=P] [background_units=B] | motors M | plc0 P | \
background B | starve | supply MV | init | power [dpram_fault] [flash_fault] [bootstrap] | \
checksum firmware|user_program | clear_rti_reentry | step N | servo N | state | home-flag M AT|none | \
following-error M COUNTS | limit M plus|minus on|off | help";

fn number<T: std::str::FromStr>(word: Option<&str>, what: &str) -> Result<T, String> {
    let w = word.ok_or_else(|| format!("missing {what}"))?;
    w.parse().map_err(|_| format!("`{w}` is not a valid {what}"))
}

fn no_more<'a>(mut words: impl Iterator<Item = &'a str>) -> Result<(), String> {
    match words.next() {
        Some(w) => Err(format!("unexpected `{w}`")),
        None => Ok(()),
    }
}

impl Control {
    /// Parses one line; the error says what is wrong and, for an unknown command, lists them.
    pub fn parse(line: &str) -> Result<Control, String> {
        let mut words = line.split_whitespace();
        let Some(verb) = words.next() else {
            return Err(format!("empty line; {HELP}"));
        };
        let load = |motors, plc0_units, background_units| Control::Load { motors, plc0_units, background_units };
        let c = match verb.to_ascii_lowercase().as_str() {
            "load" => {
                let (mut m, mut p, mut b) = (None, None, None);
                for w in words.by_ref() {
                    let (key, value) = w.split_once('=').ok_or_else(|| format!("`{w}`: expected key=value"))?;
                    match key {
                        "motors" => m = Some(number(Some(value), "motor count (0..255)")?),
                        "plc0_units" | "plc0" => p = Some(number(Some(value), "PLC 0 cost (0..65535)")?),
                        "background_units" | "background" => {
                            b = Some(number(Some(value), "background cost (0..65535)")?)
                        }
                        _ => return Err(format!("`{key}`: the load has motors, plc0_units, background_units")),
                    }
                }
                if (m, p, b) == (None, None, None) {
                    return Err("load: give at least one of motors=, plc0_units=, background_units=".into());
                }
                load(m, p, b)
            }
            "motors" => load(Some(number(words.next(), "motor count (0..255)")?), None, None),
            "plc0" => load(None, Some(number(words.next(), "PLC 0 cost (0..65535)")?), None),
            "background" => load(None, None, Some(number(words.next(), "background cost (0..65535)")?)),
            "starve" => Control::Starve,
            "supply" => Control::Supply { millivolts: number(words.next(), "supply in millivolts")? },
            "init" => Control::Reset(ResetEvent {
                kind: ResetKind::Init,
                dpram_fault: false,
                flash_fault: false,
                bootstrap: false,
            }),
            "power" => {
                let mut r =
                    ResetEvent { kind: ResetKind::Power, dpram_fault: false, flash_fault: false, bootstrap: false };
                for w in words.by_ref() {
                    match w {
                        "dpram_fault" => r.dpram_fault = true,
                        "flash_fault" => r.flash_fault = true,
                        "bootstrap" => r.bootstrap = true,
                        _ => return Err(format!("`{w}`: power takes dpram_fault, flash_fault, bootstrap")),
                    }
                }
                Control::Reset(r)
            }
            "checksum" => match words.next() {
                Some("firmware") => Control::ChecksumFault(ChecksumTarget::Firmware),
                Some("user_program") => Control::ChecksumFault(ChecksumTarget::UserProgram),
                _ => return Err("checksum takes firmware or user_program".into()),
            },
            "clear_rti_reentry" => Control::ClearRtiReentry,
            "step" => Control::Step { cycles: number(words.next(), "number of servo cycles (up to 4294967295)")? },
            "servo" => Control::Servo { cycles: number(words.next(), "number of servo cycles (up to 4294967295)")? },
            "state" => Control::State,
            "home-flag" => {
                let motor = number(words.next(), "motor number (1..8)")?;
                let at = match words.next() {
                    Some("none") => None,
                    w => Some(number(w, "position in counts")?),
                };
                Control::HomeFlag { motor, at }
            }
            "limit" => {
                let motor = number(words.next(), "motor number (1..8)")?;
                let plus = match words.next() {
                    Some("plus") => true,
                    Some("minus") => false,
                    _ => return Err("limit M plus|minus on|off: which end, plus or minus".into()),
                };
                let on = match words.next() {
                    Some("on") => true,
                    Some("off") => false,
                    _ => return Err("limit M plus|minus on|off: on (hit) or off (clear)".into()),
                };
                Control::Limit { motor, plus, on }
            }
            "following-error" => Control::FollowingError {
                motor: number(words.next(), "motor number (1..8)")?,
                counts: number(words.next(), "following error in counts")?,
            },
            "help" => Control::Help,
            other => return Err(format!("unknown command `{other}`; {HELP}")),
        };
        no_more(words)?;
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_commands_parse() {
        assert_eq!(
            Control::parse("load motors=8 plc0_units=30"),
            Ok(Control::Load { motors: Some(8), plc0_units: Some(30), background_units: None })
        );
        assert_eq!(Control::parse("starve"), Ok(Control::Starve));
        assert_eq!(Control::parse("supply 4500"), Ok(Control::Supply { millivolts: 4500 }));
        assert!(matches!(Control::parse("power bootstrap"), Ok(Control::Reset(r)) if r.bootstrap && !r.dpram_fault));
        assert_eq!(Control::parse("step 4000000000"), Ok(Control::Step { cycles: 4_000_000_000 }));
        assert!(Control::parse("step 10000000000").unwrap_err().contains("up to 4294967295"));
    }

    #[test]
    fn bad_lines_say_what_is_wrong() {
        assert!(Control::parse("").unwrap_err().contains("empty line"));
        assert!(Control::parse("fly").unwrap_err().contains("unknown command `fly`; commands:"));
        assert!(Control::parse("motors 300").unwrap_err().contains("`300` is not a valid motor count"));
        assert!(Control::parse("load speed=3").unwrap_err().contains("`speed`"));
        assert!(Control::parse("init now").unwrap_err().contains("unexpected `now`"));
        assert!(Control::parse("servo").unwrap_err().contains("missing number"));
    }

    #[test]
    fn a_line_longer_than_the_maximum_is_an_error_not_a_growing_buffer() {
        // A control client that never sends a newline used to be buffered without limit (528
        // MB measured through the proxy); the reader stops at the maximum and says so.
        let mut line = Vec::new();
        let mut ok = io::BufReader::new(&b"state\nhelp"[..]);
        assert!(read_line_max(&mut ok, &mut line, 16).unwrap());
        assert_eq!(line, b"state\n");
        assert!(read_line_max(&mut ok, &mut line, 16).unwrap());
        assert_eq!(line, b"help", "the last bytes before the end");
        assert!(!read_line_max(&mut ok, &mut line, 16).unwrap());
        let endless = io::repeat(b'x').take(1 << 30);
        let e = read_line_max(&mut io::BufReader::new(endless), &mut line, CONTROL_LINE_BYTES_MAX).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(line.len() <= CONTROL_LINE_BYTES_MAX);
    }
}
