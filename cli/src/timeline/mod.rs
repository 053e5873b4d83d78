//! `pmacwd timeline`: a trace run on the model, drawn over absolute servo cycles and
//! milliseconds: Y:$25, X:$25, the strobe, the trip, the background cycles and every status
//! bit, as CSV, as VCD for GTKWave, or as an SVG plot (docs/commands.md).

mod csv;
mod svg;
mod vcd;

use crate::common::load_spec;
use pmacwd_capture::timeline::{self, Header, Item};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TimelineFormat {
    /// One line per change: cycle, ms, Y:$25, X:$25, strobe, tripped, background, then every
    /// status bit; host reads as comment lines.
    Csv,
    /// Value change dump for GTKWave: time in ns at the servo clock.
    Vcd,
    /// A plot of Y:$25 and X:$25 against time, the trip and the host's reads marked.
    Svg,
}

pub struct TimelineArgs {
    pub trace: PathBuf,
    pub format: TimelineFormat,
    pub output: Option<PathBuf>,
    pub profile: Option<String>,
    pub specs: Option<PathBuf>,
}

/// A writer of one format: fed every item, then finished.
trait Sink {
    fn item(&mut self, header: &Header, item: Item) -> std::io::Result<()>;
    fn finish(&mut self, header: &Header) -> std::io::Result<()>;
}

pub fn timeline(args: TimelineArgs) -> ExitCode {
    let spec = match load_spec(&args.specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let out: Box<dyn Write> = match &args.output {
        Some(p) => match std::fs::File::create(p) {
            Ok(f) => Box::new(std::io::BufWriter::new(f)),
            Err(e) => {
                eprintln!("pmacwd: {}: cannot write: {e}", p.display());
                return ExitCode::from(2);
            }
        },
        None => Box::new(std::io::BufWriter::new(std::io::stdout().lock())),
    };
    let mut sink: Box<dyn Sink> = match args.format {
        TimelineFormat::Csv => Box::new(csv::Csv::new(out)),
        TimelineFormat::Vcd => Box::new(vcd::Vcd::new(out)),
        TimelineFormat::Svg => {
            let name =
                args.trace.file_name().map_or_else(|| args.trace.display().to_string(), |n| n.to_string_lossy().into());
            Box::new(svg::Svg::new(out, name))
        }
    };
    let walked = timeline::walk(&spec, &args.trace, args.profile.as_deref(), |h, item| sink.item(h, item));
    let written = match walked {
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
        Ok(w) => w.and_then(|header| sink.finish(&header)),
    };
    match written {
        Ok(()) => ExitCode::SUCCESS,
        // A reader that stopped early (`| head`) is not an error.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("pmacwd: cannot write the timeline: {e}");
            ExitCode::from(2)
        }
    }
}
