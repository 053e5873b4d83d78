//! `pmacwd import`: a plain host log (commands and replies, the servo counter X:$0 read
//! alongside) turned into a trace. The log format is documented in `docs/capturing.md`:
//!
//! ```text
//! # comment
//! > ???
//! < 001000000000
//! > RHX:$0
//! < 01A2B3
//! ```
//!
//! Every command becomes a `command` step expecting its reply. A host cannot see background
//! cycles, so the time between two X:$0 reads becomes a `run` step (servo cycles with the
//! background completing whenever the load allows), placed before the command that read the
//! counter; commands between two counter reads are placed at the earlier read. The counter's
//! own value is kept as the step's note, not compared: the model's X:$0 starts at 0 at
//! power-up, the card's somewhere else.

use pmacwd_specs::check::{AllKeyword, ProfileSelection};
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Position, SpecError};
use pmacwd_trace::{Expect, Step, Trace, TraceEvent, FORMAT_VERSION};
use std::path::Path;

/// The servo cycle counter wraps at 2^24 (M100->X:$000000,0,24,U).
const SERVO_COUNTER_MODULUS: u32 = 1 << 24;

pub fn import(file: &Path, text: &str, configuration: &str) -> Result<Trace, SpecError> {
    let err = |line: usize, column: usize, msg: String| SpecError::at(file, Position { line, column }, msg);
    let mut steps = Vec::new();
    let mut last_counter: Option<u32> = None;
    let mut pending: Option<(usize, String, HostCommand)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim_end();
        if l.trim().is_empty() || l.trim_start().starts_with('#') {
            continue;
        }
        if let Some(cmd) = l.strip_prefix("> ") {
            if let Some((at, text, _)) = &pending {
                return Err(err(*at, 1, format!("`{text}` has no reply line (`< ...`) before the next command")));
            }
            let parsed = HostCommand::parse(cmd).map_err(|e| err(line, 3, e.0))?;
            pending = Some((line, cmd.trim().to_string(), parsed));
        } else if let Some(reply) = l.strip_prefix("< ").or_else(|| (l == "<").then_some("")) {
            let Some((_, _, cmd)) = pending.take() else {
                return Err(err(line, 1, "a reply line without a command before it".into()));
            };
            let reply = reply.trim();
            let expected = match reply {
                "(timeout)" => "(silence)".to_string(),
                "" => "(ack)".to_string(),
                r => r.to_ascii_uppercase(),
            };
            let mut note = None;
            let mut expect = Expect { reply: Some(expected), ..Expect::default() };
            if cmd == HostCommand::ReadHex(Register::ServoCycles) && reply != "(timeout)" {
                let value = u32::from_str_radix(reply, 16)
                    .ok()
                    .filter(|v| *v < SERVO_COUNTER_MODULUS)
                    .ok_or_else(|| err(line, 3, format!("X:$0 reply `{reply}` is not a 24-bit hex word")))?;
                if let Some(prev) = last_counter {
                    let cycles = (value + SERVO_COUNTER_MODULUS - prev) % SERVO_COUNTER_MODULUS;
                    if cycles > 0 {
                        steps.push(Step { event: TraceEvent::Run { cycles }, expect: Expect::default(), note: None });
                    }
                }
                last_counter = Some(value);
                note = Some(format!("the card's X:$0 read {reply} (used for timing, not compared)"));
                expect = Expect::default();
            }
            if cmd == HostCommand::Reset {
                // The card restarts its servo counter, and resets rather than answers: what the
                // log shows after `$$$` is the link's, not the model's, so it is kept as a note.
                last_counter = None;
                note = Some(format!("reply `{reply}` not compared: the card resets"));
                expect = Expect::default();
            }
            steps.push(Step { event: TraceEvent::Model(Event::Command(cmd)), expect, note });
        } else {
            return Err(err(line, 1, "expected `> command`, `< reply`, a `#` comment or a blank line".into()));
        }
    }
    if let Some((at, text, _)) = pending {
        return Err(err(at, 1, format!("`{text}` has no reply line at the end of the log")));
    }
    if steps.is_empty() {
        return Err(SpecError::whole_file(file, "the log has no commands"));
    }
    Ok(Trace {
        version: FORMAT_VERSION,
        description: format!("imported from the host log {}", file.display()),
        cite: None,
        configuration: configuration.to_string(),
        profiles: ProfileSelection::Keyword(AllKeyword::All),
        steps,
    })
}
