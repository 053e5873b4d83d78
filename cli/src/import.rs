//! `pmacwd import`: a plain host log to a trace, streamed: the log is read one line at a time,
//! twice (first what it says about the card, for the header; then the steps, each written as
//! it is complete), so memory does not grow with the log.
//!
//! With `--out FILE` the trace goes to a temporary file beside FILE, renamed to FILE only when
//! the whole log imported, so a failed import never leaves a half trace under FILE. On standard
//! output the steps before an error have already been written; the error and exit code 2 say
//! the trace is incomplete.

use crate::common::{plural, unusable};
use pmacwd_capture::import::{configuration_servo_hz, ImportStream};
use pmacwd_specs::Spec;
use pmacwd_trace::{CardConfig, Step};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// How the trace is written: JSON Lines or YAML, one step at a time (`--format`; `--yaml` is
/// `--format yaml`). The trace is import's report, so `--format` names its form as it names
/// every other command's output (docs/json.md); the log's own kind is `--log-format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    Jsonl,
    Yaml,
}

impl Form {
    /// `--format` of `pmacwd import`, for clap's `value_parser`: `jsonl` or `yaml`. A kind of
    /// log there (`--format asyn`, what import's `--format` meant before issue 34) is refused
    /// with the flag it belongs to, and `json` with the form import writes.
    pub fn parse(text: &str) -> Result<Form, String> {
        match text {
            "jsonl" => Ok(Form::Jsonl),
            "yaml" => Ok(Form::Yaml),
            "host-log" | "asyn" | "pcap" => Err(format!(
                "`{text}` is a kind of log: name it with --log-format {text}; --format names the trace written, \
                 jsonl or yaml (docs/commands.md)"
            )),
            "json" => Err("import writes a trace as JSON Lines, one JSON object a line (docs/trace-format.md): \
                           give --format jsonl, or yaml"
                .to_string()),
            _ => Err("give jsonl or yaml (the trace written; the log's kind is --log-format)".to_string()),
        }
    }
}

impl Form {
    fn header(
        self,
        out: &mut dyn Write,
        trace: &pmacwd_trace::Trace,
        card: Option<&CardConfig>,
    ) -> std::io::Result<()> {
        match self {
            Form::Jsonl => writeln!(out, "{}", pmacwd_trace::jsonl::header_line_with_card(trace, card)),
            Form::Yaml => out.write_all(pmacwd_trace::yaml_header_with_card(trace, card).as_bytes()),
        }
    }
    fn step(self, out: &mut dyn Write, step: &Step) -> std::io::Result<()> {
        match self {
            Form::Jsonl => writeln!(out, "{}", pmacwd_trace::jsonl::step_line(step)),
            Form::Yaml => out.write_all(pmacwd_trace::yaml_step(step).as_bytes()),
        }
    }
}

pub fn import_log(
    log: &Path,
    out: Option<PathBuf>,
    configuration: &str,
    form: Form,
    format: Option<pmacwd_capture::import::LogFormat>,
) -> ExitCode {
    let spec = match Spec::embedded() {
        Ok(spec) => spec,
        Err(e) => return unusable(e),
    };
    // The configuration is checked now, not at replay: the trace would name one that does not
    // exist.
    if let Err(e) = configuration_servo_hz(&spec, configuration) {
        return unusable(format!("--configuration: {e}"));
    }
    // The first pass (what the log says about the card) reads the whole log before anything
    // is written: its errors leave no output at all.
    let mut stream = match ImportStream::open_as(&spec, log, configuration, format) {
        Ok(s) => s,
        Err(e) => return unusable(e),
    };
    match out {
        Some(path) => {
            let partial = partial_path(&path);
            let result = std::fs::File::create(&partial)
                .map_err(|e| format!("{}: cannot write: {e}", partial.display()))
                .and_then(|f| {
                    let mut w = BufWriter::new(f);
                    let steps = write_trace(&mut stream, form, &mut w, log)?;
                    w.flush().map_err(|e| format!("{}: cannot write: {e}", partial.display()))?;
                    Ok(steps)
                })
                .and_then(|steps| {
                    std::fs::rename(&partial, &path).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
                    Ok(steps)
                });
            match result {
                Ok(steps) => {
                    eprintln!("pmacwd: wrote {} to {}", plural(steps, "step", "steps"), path.display());
                    summarize(&stream, configuration);
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    let _ = std::fs::remove_file(&partial);
                    unusable(e)
                }
            }
        }
        None => {
            let stdout = std::io::stdout();
            let mut w = BufWriter::new(stdout.lock());
            let result = write_trace(&mut stream, form, &mut w, log);
            let _ = w.flush();
            match result {
                Ok(_) => {
                    summarize(&stream, configuration);
                    ExitCode::SUCCESS
                }
                Err(e) => unusable(e),
            }
        }
    }
}

/// The import summary on standard error: which values came from the log and which from the
/// configuration, what was kept without being modelled, and a warning when the log gives no
/// timing.
fn summarize(stream: &ImportStream, configuration: &str) {
    let from_log: Vec<String> = stream
        .from_log
        .sources
        .iter()
        .map(|(field, var, v, line)| format!("{field} ({var} = {v}, line {line})"))
        .collect();
    let fields = ["servo_hz", "i8", "i40", "i41"];
    let from_config: Vec<&str> =
        fields.into_iter().filter(|f| !stream.from_log.sources.iter().any(|(g, ..)| g == f)).collect();
    if !from_log.is_empty() {
        eprintln!("pmacwd: from the log: {}", from_log.join(", "));
    }
    if !from_config.is_empty() {
        eprintln!("pmacwd: from configuration `{configuration}`: {}", from_config.join(", "));
    }
    for passed in stream.passed_over() {
        eprintln!("pmacwd: passed over ({}): {passed}", stream.format.name());
    }
    let Some(s) = stream.summary() else { return };
    eprintln!(
        "pmacwd: {} on {}, {}, {}, {} timed by the host clock, {} of unknown length (a timeout in a log without stamps), {} timed by stamped replies, {} answered from the card's own state \
         (not compared with the model's values), {} the grammar cannot read (kept without an expectation){}{}",
        plural(s.commands, "command", "commands"),
        plural(s.exchanges, "line", "lines"),
        plural(s.counter_reads, "X:$0 read", "X:$0 reads"),
        plural(s.restarts, "restart", "restarts"),
        plural(s.silent_gaps, "silent gap", "silent gaps"),
        plural(s.waits_unknown, "wait", "waits"),
        plural(s.waits_timed, "unanswered wait", "unanswered waits"),
        s.card_own,
        s.not_modelled,
        if s.unseen > 0 {
            format!(", {} answered but not shown in full (kept without an expectation)", s.unseen)
        } else {
            String::new()
        },
        if s.stamped { format!(", host time at {} Hz", stream.servo_hz) } else { String::new() }
    );
    if let Some(w) = s.timing_warning() {
        eprintln!("pmacwd: {w}");
    }
}

/// `FILE.partial` beside `FILE`.
fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Imports the log into `out`; the number of steps written.
fn write_trace(stream: &mut ImportStream, form: Form, out: &mut dyn Write, log: &Path) -> Result<u64, String> {
    let write_error = |e: std::io::Error| format!("cannot write the trace: {e}");
    form.header(out, &stream.header, stream.card.as_ref()).map_err(write_error)?;
    let mut nodes = YamlNodes::default();
    if let Form::Yaml = form {
        nodes.header(&pmacwd_trace::yaml_header_with_card(&stream.header, stream.card.as_ref()));
    }
    let mut steps = 0u64;
    while let Some((line, step)) = stream.next_step().map_err(|e| e.to_string())? {
        if let Form::Yaml = form {
            nodes.step(&pmacwd_trace::yaml_step(&step)).map_err(|n| {
                format!(
                    "{}:{line}: the YAML trace would have {n} nodes with this step, more than the {} `run` \
                     and `replay` read: import the log as JSON Lines (--format jsonl), which they read a \
                     step at a time",
                    log.display(),
                    pmacwd_specs::yaml::NODES_MAX
                )
            })?;
        }
        form.step(out, &step).map_err(write_error)?;
        steps += 1;
    }
    Ok(steps)
}

/// The nodes of a YAML trace written a step at a time, as the readers count them
/// ([`pmacwd_specs::yaml::NODES_MAX`]): a longer one would be written only to be refused.
#[derive(Default)]
struct YamlNodes(usize);

impl YamlNodes {
    /// The header ends with `steps:`, whose empty value stands for the sequence of steps.
    fn header(&mut self, text: &str) {
        self.0 = pmacwd_specs::yaml::node_count(text).unwrap_or(0);
    }

    /// A step is written as an item (`  - command: ...`): alone it parses as a sequence of one,
    /// and that sequence is the header's.
    fn step(&mut self, text: &str) -> Result<(), usize> {
        self.0 += pmacwd_specs::yaml::node_count(text).unwrap_or(1).saturating_sub(1);
        if self.0 > pmacwd_specs::yaml::NODES_MAX {
            return Err(self.0);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_yaml_node_tally_of_an_import_is_the_count_of_the_whole_trace() {
        // `import --yaml` stops before its trace passes what the readers take; the tally it
        // keeps step by step must be the count a reader makes of the whole file.
        let dir = std::env::temp_dir().join(format!("pmacwd-import-tally-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let log = dir.join("s.log");
        let mut text = String::new();
        for i in 0..50 {
            text.push_str(&format!("> RHX:$0\n< {:06X}\n> ???\n< 001000000000\n> I40\n< 0\n", i * 300));
        }
        std::fs::write(&log, text).unwrap();
        let spec = Spec::embedded().unwrap();
        let mut stream = ImportStream::open(&spec, &log, "host-log").unwrap();
        let mut out = Vec::new();
        write_trace(&mut stream, Form::Yaml, &mut out, &log).unwrap();
        let written = String::from_utf8(out).unwrap();
        let whole = pmacwd_specs::yaml::node_count(&written).unwrap();
        let mut nodes = YamlNodes::default();
        let (header, steps) = written.split_at(written.find("steps:\n").unwrap() + "steps:\n".len());
        nodes.header(header);
        // The tally again, over the text as written: each step begins at a line `  - `.
        let mut items: Vec<String> = Vec::new();
        for line in steps.lines() {
            if line.starts_with("  - ") {
                items.push(String::new());
            }
            let item = items.last_mut().unwrap();
            item.push_str(line);
            item.push('\n');
        }
        for item in &items {
            nodes.step(item).unwrap();
        }
        assert_eq!(nodes.0, whole, "{written}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
