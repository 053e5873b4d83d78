//! `pmacwd probe ADDR`: a seeded campaign of command sequences sent to a card (or a simulator)
//! over its Ethernet protocol or a terminal server, recorded as a stamped host log, and judged
//! by the replay search, again without each unit that had a fault (docs/probe.md).

mod campaign;
mod check;
mod judge;
mod log;
mod report;
mod wire;

use crate::common::Format;
use crate::common::{load_spec, unusable};
use campaign::{Allow, Rng, Session, Touch};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant, SystemTime};

/// Test a card or a simulator over the wire against the manuals' safety core.
#[derive(clap::Args)]
pub struct ProbeArgs {
    /// The card: HOST or HOST:PORT (port 1025, the card's Ethernet protocol; 23 with --telnet).
    #[arg(value_name = "ADDR")]
    pub address: String,
    /// Talk to a terminal server's plain line instead (the line and a CR out, the card's
    /// framed answers back).
    #[arg(long)]
    pub telnet: bool,
    /// The campaign's seed (default: from the clock); printed first, so a run can be repeated.
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// How many times the campaign's basic units are drawn, 1..20.
    #[arg(long, allow_negative_numbers = true, value_name = "N", default_value_t = 1, value_parser = crate::common::ranged(1u32, 20, ""))]
    pub rounds: u32,
    /// Only these kinds of unit, comma-separated: identity, poll, i40, i41, errors, checksum,
    /// stop, bit22, reset, reinitialize, trip (each still only where the --allow flags permit; bit22, which
    /// needs --control and --allow-writes, only when named: docs/probe.md says why).
    #[arg(long, value_name = "KINDS", value_delimiter = ',', value_parser = ["identity", "poll", "i40", "i41", "errors", "checksum", "stop", "bit22", "reset", "reinitialize", "trip"])]
    pub units: Option<Vec<String>>,
    /// Where to write the host log (default: pmacwd-probe-SEED.log in the current directory).
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Only reads: no unit that writes anything, even reversibly.
    #[arg(long, conflicts_with_all = ["allow_writes", "allow_reset", "allow_trip"])]
    pub read_only: bool,
    /// Also writes that are not read back and restored in the same unit: I41 bits 2 and 3
    /// (I7999, I8191), and, with --control, PLC 0 loads on the emulator.
    #[arg(long)]
    pub allow_writes: bool,
    /// Also `$$$`, and `$$$***` then `$$$` (resets: unsaved changes are lost); the campaign
    /// then starts with a `$$$`, which makes its judgment fast (docs/probe.md).
    #[arg(long)]
    pub allow_reset: bool,
    /// Also starve the background until the watchdog trips (a PLC 0 download, or --control's
    /// `starve`), then recover by INIT/: simulators and bench cards only.
    #[arg(long)]
    pub allow_trip: bool,
    /// Needed before anything is written to a card that is not on loopback.
    #[arg(long)]
    pub yes: bool,
    /// The control port of `pmacwd serve` (HOST:PORT): load and INIT/ come from there.
    #[arg(long, value_name = "ADDR", value_parser = crate::common::listen_address)]
    pub control: Option<std::net::SocketAddr>,
    /// No reply byte for this long is silence (a tripped card), 50..60000 ms.
    #[arg(long, allow_negative_numbers = true, value_name = "MS", default_value_t = 1000, value_parser = crate::common::ranged(50u64, 60_000, " ms"))]
    pub silence_ms: u64,
    /// How long the search may judge one segment before it is undecided, 1..3600 s.
    #[arg(long, allow_negative_numbers = true, value_name = "SECONDS", default_value_t = 60, value_parser = crate::common::ranged(1u64, 3600, " s"))]
    pub judge_seconds: u64,
    /// After a trip without --control: how long to wait for INIT/ or a power cycle, 1..3600 s.
    #[arg(long, allow_negative_numbers = true, value_name = "SECONDS", default_value_t = 120, value_parser = crate::common::ranged(1u64, 3600, " s"))]
    pub recover_seconds: u64,
    /// Print the plan and stop, without connecting.
    #[arg(long)]
    pub plan_only: bool,
    /// Output format: text, or the report as one JSON document (docs/json.md gives its
    /// schema; the seed and plan lines then go to standard error).
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
}

pub fn probe(a: ProbeArgs) -> ExitCode {
    let transport = if a.telnet { wire::Transport::Telnet } else { wire::Transport::Ethernet };
    let addr = match wire::resolve(&a.address, transport) {
        Ok(addr) => addr,
        Err(e) => return unusable(e),
    };
    let seed = a.seed.unwrap_or_else(|| {
        SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map_or(1, |d| d.as_nanos() as u64 % 1_000_000_000)
    });
    let json = matches!(a.format, Format::Json);
    // The seed first, so that a run can be repeated whatever happens next.
    let say = |line: String| if json { eprintln!("{line}") } else { println!("{line}") };
    say(format!("pmacwd probe {addr} ({}): seed {seed}", if a.telnet { "telnet" } else { "Ethernet" }));
    let allow = Allow {
        read_only: a.read_only,
        writes: a.allow_writes,
        reset: a.allow_reset,
        trip: a.allow_trip,
        control: a.control.is_some(),
        bit22: a.units.as_ref().is_some_and(|u| u.iter().any(|k| k == "bit22")),
    };
    let units = campaign::plan(seed, allow, a.rounds, a.units.as_deref());
    if units.is_empty() {
        return unusable("the plan is empty: --units names no kind the --allow flags permit");
    }
    say(format!("plan: {} units", units.len()));
    for (i, u) in units.iter().enumerate() {
        say(format!("  {i:>3} {:<44} {}", u.name(), u.effect(a.control.is_some())));
    }
    let writes = units.iter().any(|u| u.touch() > Touch::Reads);
    if a.plan_only {
        return ExitCode::SUCCESS;
    }
    if writes && !addr.ip().is_loopback() && !a.yes {
        return unusable(format!(
            "the plan writes to the card at {addr} (every I-variable is read first and written back): \
             add --yes to run it, or --read-only for reads alone"
        ));
    }
    let spec = match load_spec(&a.specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let log_path = a.log.clone().unwrap_or_else(|| PathBuf::from(format!("pmacwd-probe-{seed}.log")));
    let mut link = match wire::Link::connect(addr, transport, Duration::from_millis(a.silence_ms)) {
        Ok(l) => l,
        Err(e) => return unusable(e),
    };
    let mut control = match a.control.map(wire::ControlPort::connect).transpose() {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let mut host_log = match log::HostLog::create(&log_path) {
        Ok(l) => l,
        Err(e) => return unusable(e),
    };
    let header = format!(
        "pmacwd probe {addr} ({}), seed {seed}: a campaign of {} units, each starting at an X:$0 read\n\
         judge it again with: pmacwd replay {}",
        if a.telnet { "telnet" } else { "Ethernet" },
        units.len(),
        log_path.display()
    );
    if let Err(e) = host_log.comment(&header) {
        return unusable(e);
    }

    let started = Instant::now();
    let mut rng = Rng::new(seed ^ 0x5EED);
    let mut cut_short = Vec::new();
    {
        let mut session = Session {
            link: &mut link,
            control: control.as_mut(),
            log: &mut host_log,
            unit: 0,
            servo_hz: 2250.0,
            i40: 0,
            recover: Duration::from_secs(a.recover_seconds),
            last_poll: None,
            last_read: None,
            last_error: None,
        };
        if allow.reset && !allow.read_only {
            if let Err(e) = session.reset_first() {
                eprintln!("pmacwd probe: the first reset: {e}; the log so far is {}", log_path.display());
                return ExitCode::from(2);
            }
        }
        for (i, u) in units.iter().enumerate() {
            session.unit = i;
            match session.run(u, &mut rng) {
                Ok(None) => {}
                Ok(Some(why)) => cut_short.push((i, u.name(), why)),
                Err(e) => {
                    eprintln!("pmacwd probe: unit {i} ({}): {e}; the log so far is {}", u.name(), log_path.display());
                    return ExitCode::from(2);
                }
            }
        }
    }
    let campaign_seconds = started.elapsed().as_secs_f64();
    let exchanges = match host_log.finish() {
        Ok(x) => x,
        Err(e) => return unusable(e),
    };

    let dir = std::env::temp_dir().join(format!("pmacwd-probe-{}-{seed}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        return unusable(format!("{}: {e}", dir.display()));
    }
    let judging = Instant::now();
    let names: Vec<String> = units.iter().map(campaign::Unit::name).collect();
    let verdict = judge::judge_all(&spec, &dir, &exchanges, &names, Duration::from_secs(a.judge_seconds));
    let _ = std::fs::remove_dir_all(&dir);
    let verdict = match verdict {
        Ok(v) => v,
        Err(e) => return unusable(e),
    };
    let run = report::Run {
        address: addr.to_string(),
        transport: if a.telnet { "telnet" } else { "Ethernet" },
        seed,
        log: log_path.display().to_string(),
        units: units.len(),
        lines: exchanges.len(),
        campaign_seconds,
        judge_seconds: judging.elapsed().as_secs_f64(),
        cut_short,
        verdict,
    };
    if json {
        println!("{}", crate::common::json_document("probe", crate::common::json_version::PROBE, report::json(&run)));
    } else {
        print!("{}", report::text(&run));
    }
    ExitCode::from(run.exit())
}
