//! Where a capture's steps come from, one at a time: a YAML trace, a JSON Lines capture, or a
//! host log imported on the fly. `pmacwd replay` judges them by search ([`crate::explain`]).

use pmacwd_specs::profiles::Profile;
use pmacwd_specs::yaml::SourceMap;
use pmacwd_specs::{Position, Spec, SpecError};
use pmacwd_trace::jsonl::StepReader;
use pmacwd_trace::{parse_yaml, Step, Trace};
use std::io::{BufRead, BufReader};
use std::path::Path;

/// How a log given to `pmacwd replay` is imported: under which configuration (default
/// [`crate::import::DEFAULT_CONFIGURATION`]) and read in which format (default: by its content).
#[derive(Clone, Copy, Debug, Default)]
pub struct ImportAs<'a> {
    pub configuration: Option<&'a str>,
    pub format: Option<crate::import::LogFormat>,
    /// Where the commands between X:$0 reads go (`pmacwd replay` tries host time when the
    /// reads' instants do not explain a stamped log).
    pub placement: crate::import::Placement,
    /// How long the search placing a log by host time may take before the verdict is
    /// undecided (`None`: no limit).
    pub host_time_limit: Option<std::time::Duration>,
    /// When the search must stop (set from `host_time_limit` for the host-time pass).
    pub deadline: Option<std::time::Instant>,
    /// The card's saved I40 where the capture does not say it (`--i40`, or a value the search
    /// tries for a log that never reads I40: [`crate::explain::unknown`]).
    pub card_i40: Option<i64>,
}

impl<'a> From<Option<&'a str>> for ImportAs<'a> {
    fn from(configuration: Option<&'a str>) -> ImportAs<'a> {
        ImportAs {
            configuration,
            format: None,
            placement: crate::import::Placement::AtReads,
            host_time_limit: None,
            deadline: None,
            card_i40: None,
        }
    }
}

/// Where steps come from: a YAML trace (short, read whole), a JSON Lines capture (streamed),
/// or a host log imported on the fly (streamed through the importer, `docs/capturing.md`).
pub enum Source {
    Yaml { trace: Trace, map: SourceMap, next: usize, card: Option<pmacwd_specs::config::CardConfig> },
    Jsonl(StepReader<BufReader<std::fs::File>>),
    HostLog(Box<crate::import::ImportStream>),
}

impl Source {
    /// Opens `path` as [`Source::open`] does, and a host log as [`Source::HostLog`], imported
    /// under `configuration` (default [`crate::import::DEFAULT_CONFIGURATION`]). A
    /// configuration given for a trace is an error: a trace names its own.
    pub fn open_with(spec: &Spec, path: &Path, import: ImportAs<'_>) -> Result<Source, SpecError> {
        let configuration = import.configuration;
        let format = match import.format {
            Some(f) => Some(f),
            None => crate::import::looks_like(path)?,
        };
        if let Some(format) = format {
            let name = configuration.unwrap_or(crate::import::DEFAULT_CONFIGURATION);
            return Ok(Source::HostLog(Box::new(crate::import::ImportStream::open_placed(
                spec,
                path,
                name,
                Some(format),
                import.placement,
            )?)));
        }
        if let Some(name) = configuration {
            return Err(SpecError::whole_file(
                path,
                format!("--configuration {name} is for host logs; this trace names its own configuration"),
            ));
        }
        Source::open(path)
    }

    /// What the capture says about the card (its `card:` header), if anything.
    pub fn card(&self) -> Option<pmacwd_specs::config::CardConfig> {
        match self {
            Source::Yaml { card, .. } => *card,
            Source::Jsonl(r) => r.header.card,
            Source::HostLog(s) => s.card,
        }
    }

    /// What the capture says about the card, with `import`'s I40 where the capture does not
    /// say it.
    pub fn card_as(&self, import: &ImportAs<'_>) -> Option<pmacwd_specs::config::CardConfig> {
        let mut card = self.card();
        if let (Some(v), None) = (import.card_i40, card.and_then(|c| c.i40)) {
            card.get_or_insert_default().i40 = Some(v);
        }
        card
    }

    /// Opens `path`, telling the forms apart by the first non-blank character (`{` is JSON Lines;
    /// a byte-order mark counts as blank). Only regular files are read; a YAML trace is read
    /// whole up to [`pmacwd_specs::input::YAML_TRACE_BYTES_MAX`], a JSON Lines one streamed.
    pub fn open(path: &Path) -> Result<Source, SpecError> {
        let file = pmacwd_specs::input::open_regular(path)?;
        let mut reader = BufReader::new(file);
        let first = loop {
            let buf = reader.fill_buf().map_err(|e| SpecError::whole_file(path, format!("cannot read: {e}")))?;
            let bom = if buf.starts_with(&[0xEF, 0xBB, 0xBF]) { 3 } else { 0 };
            match buf[bom..].iter().position(|b| !b.is_ascii_whitespace()) {
                Some(i) => break Some(buf[bom + i]),
                None if buf.is_empty() => break None,
                None => {
                    let n = buf.len();
                    reader.consume(n);
                }
            }
        };
        match first {
            None => Err(SpecError::whole_file(path, "empty trace")),
            Some(b'{') => Ok(Source::Jsonl(StepReader::new(path, reader)?)),
            Some(_) => {
                let text = pmacwd_specs::input::read_text(path, pmacwd_specs::input::YAML_TRACE_BYTES_MAX)?;

                let loaded = parse_yaml(path, &text)?;
                Ok(Source::Yaml { trace: loaded.trace, map: loaded.map, next: 0, card: loaded.card })
            }
        }
    }

    /// The profiles the capture asks to be judged under (`all`, or the names it lists), each
    /// name checked against the spec.
    pub fn profiles(&self, spec: &Spec, path: &Path) -> Result<Vec<Profile>, SpecError> {
        let (selection, at) = match self {
            Source::Yaml { trace, map, .. } => (&trace.profiles, map.position("profiles")),
            Source::Jsonl(r) => (&r.header.profiles, Position { line: 1, column: 1 }),
            Source::HostLog(s) => (&s.header.profiles, Position { line: 1, column: 1 }),
        };
        spec.profiles.select(selection).map_err(|(_, n)| {
            SpecError::at(path, at, format!("no profile named `{n}` (profiles: {})", spec.profiles.names()))
        })
    }

    pub fn configuration(&self) -> &str {
        match self {
            Source::Yaml { trace, .. } => &trace.configuration,
            Source::Jsonl(r) => &r.header.configuration,
            Source::HostLog(s) => &s.header.configuration,
        }
    }

    pub fn description(&self) -> &str {
        match self {
            Source::Yaml { trace, .. } => &trace.description,
            Source::Jsonl(r) => &r.header.description,
            Source::HostLog(s) => &s.header.description,
        }
    }

    /// The next step with the line it is written on.
    pub fn next_step(&mut self) -> Result<Option<(usize, Step)>, SpecError> {
        match self {
            Source::Yaml { trace, map, next, .. } => {
                let Some(step) = trace.steps.get(*next) else { return Ok(None) };
                let line = map.position(&format!("steps.{next}")).line;
                *next += 1;
                Ok(Some((line, step.clone())))
            }
            Source::Jsonl(r) => r.next_step(),
            Source::HostLog(s) => s.next_step(),
        }
    }
}
