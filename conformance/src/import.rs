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
use std::path::{Path, PathBuf};

/// The servo cycle counter wraps at 2^24 (M100->X:$000000,0,24,U).
const SERVO_COUNTER_MODULUS: u32 = 1 << 24;

/// A host log read one line at a time: memory stays bounded whatever the log's length.
pub struct Importer {
    file: PathBuf,
    last_counter: Option<u32>,
    /// The command waiting for its reply: (line, text, command).
    pending: Option<(usize, String, HostCommand)>,
    commands: u64,
}

impl Importer {
    pub fn new(file: &Path) -> Importer {
        Importer { file: file.to_path_buf(), last_counter: None, pending: None, commands: 0 }
    }

    fn err(&self, line: usize, column: usize, msg: String) -> SpecError {
        SpecError::at(&self.file, Position { line, column }, msg)
    }

    /// Reads line `line` of the log; returns the steps it completes (zero, one or two).
    pub fn line(&mut self, line: usize, raw: &str) -> Result<Vec<Step>, SpecError> {
        let l = raw.trim_end();
        if l.trim().is_empty() || l.trim_start().starts_with('#') {
            return Ok(Vec::new());
        }
        if let Some(cmd) = l.strip_prefix("> ") {
            if let Some((at, text, _)) = &self.pending {
                return Err(self.err(*at, 1, format!("`{text}` has no reply line (`< ...`) before the next command")));
            }
            let parsed = HostCommand::parse(cmd).map_err(|e| self.err(line, 3, e.0))?;
            self.pending = Some((line, cmd.trim().to_string(), parsed));
            return Ok(Vec::new());
        }
        let Some(reply) = l.strip_prefix("< ").or_else(|| (l == "<").then_some("")) else {
            return Err(self.err(line, 1, "expected `> command`, `< reply`, a `#` comment or a blank line".into()));
        };
        let Some((_, _, cmd)) = self.pending.take() else {
            return Err(self.err(line, 1, "a reply line without a command before it".into()));
        };
        self.commands += 1;
        let mut steps = Vec::new();
        let reply = reply.trim();
        let expected = match reply {
            "(timeout)" => "(silence)".to_string(),
            "" => "(ack)".to_string(),
            r => r.to_ascii_uppercase(),
        };
        let mut note = None;
        let mut expect = Expect { reply: Some(expected), ..Expect::default() };
        if cmd == HostCommand::ReadHex(Register::ServoCycles) && reply != "(timeout)" {
            // Hex digits only: `from_str_radix` would also take a sign (`+10`).
            let value = Some(reply)
                .filter(|r| !r.is_empty() && r.chars().all(|c| c.is_ascii_hexdigit()))
                .and_then(|r| u32::from_str_radix(r, 16).ok())
                .filter(|v| *v < SERVO_COUNTER_MODULUS)
                .ok_or_else(|| self.err(line, 3, format!("X:$0 reply `{reply}` is not a 24-bit hex word")))?;
            if let Some(prev) = self.last_counter {
                let cycles = (value + SERVO_COUNTER_MODULUS - prev) % SERVO_COUNTER_MODULUS;
                if cycles > 0 {
                    steps.push(Step { event: TraceEvent::Run { cycles }, expect: Expect::default(), note: None });
                }
            }
            self.last_counter = Some(value);
            note = Some(format!("the card's X:$0 read {reply} (used for timing, not compared)"));
            expect = Expect::default();
        }
        if cmd == HostCommand::Reset {
            // The card restarts its servo counter, and resets rather than answers: what the
            // log shows after `$$$` is the link's, not the model's, so it is kept as a note.
            self.last_counter = None;
            note = Some(format!("reply `{reply}` not compared: the card resets"));
            expect = Expect::default();
        }
        steps.push(Step { event: TraceEvent::Model(Event::Command(cmd)), expect, note });
        Ok(steps)
    }

    /// The end of the log: a command left without its reply, or a log without commands, is an
    /// error.
    pub fn finish(self) -> Result<(), SpecError> {
        if let Some((at, text, _)) = &self.pending {
            return Err(self.err(*at, 1, format!("`{text}` has no reply line at the end of the log")));
        }
        if self.commands == 0 {
            return Err(SpecError::whole_file(&self.file, "the log has no commands"));
        }
        Ok(())
    }
}

/// The trace an imported log becomes, without its steps (they are written as they come).
pub fn header(file: &Path, configuration: &str) -> Trace {
    Trace {
        version: FORMAT_VERSION,
        description: format!("imported from the host log {}", file.display()),
        cite: None,
        configuration: configuration.to_string(),
        profiles: ProfileSelection::Keyword(AllKeyword::All),
        steps: Vec::new(),
    }
}

/// A whole log held in memory, imported at once (for short logs and tests).
pub fn import(file: &Path, text: &str, configuration: &str) -> Result<Trace, SpecError> {
    let mut importer = Importer::new(file);
    let mut trace = header(file, configuration);
    for (i, raw) in text.lines().enumerate() {
        trace.steps.extend(importer.line(i + 1, raw)?);
    }
    importer.finish()?;
    Ok(trace)
}
