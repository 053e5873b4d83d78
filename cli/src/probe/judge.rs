//! Judging the campaign by the replay search (`pmacwd_capture::explain`), as `pmacwd replay`
//! judges a log, with a time bound: a fault is named by the check of the exchange where the
//! reading that lasted longest failed; its unit is then left out and the rest judged again
//! ([`judge_all`]).

use super::campaign::{BIT22, SERVO_COUNTER, STATUS, TRIP, WATCHDOG_COUNTER, WATCHDOG_MINIMUM};
use super::check::Check;
use super::log::{segment_text, Exchange};
use super::wire::Reply;
use pmacwd_capture::explain::report::{self, ReadingVerdict};
use pmacwd_capture::import::{LogFormat, Placement};
use pmacwd_capture::replay::ImportAs;
use pmacwd_specs::Spec;
use std::path::Path;
use std::time::{Duration, Instant};

/// An observation no correct card can show.
#[derive(Clone, Debug)]
pub struct Fault {
    pub check: &'static Check,
    /// The whole log's line of the exchange.
    pub line: usize,
    pub command: String,
    pub reply: String,
    /// What failed (from the reading of the manuals that lasted longest), what the card
    /// answered, and what a correct card in that reading's state could have answered (the
    /// replay search's `expected` is the capture's value, its `observed` the model's).
    pub what: String,
    pub card: String,
    pub correct: String,
}

/// A fault with the unit it was found in.
#[derive(Clone, Debug)]
pub struct Found {
    pub unit: usize,
    pub unit_name: String,
    pub fault: Fault,
}

/// The verdict on the whole campaign.
pub struct Verdict {
    pub faults: Vec<Found>,
    /// The readings and profiles of the last pass, when a correct card explains it (the log
    /// without the units that had a fault).
    pub readings: Vec<ReadingVerdict>,
    pub profiles: Vec<(String, bool, bool)>,
    pub explained: bool,
    /// Why no verdict was reached on what remained, if none was.
    pub undecided: Option<String>,
    /// Each pass: the units left out, its seconds.
    pub passes: Vec<(usize, f64)>,
}

/// Judges the campaign: the whole log first; at a fault, the unit it lies in is left out (the
/// host then did not see that stretch: its X:$0 reads on either side still time it) and the
/// rest is judged again from the start, until a correct card explains what remains or no
/// verdict can be reached. So every unit with an observation no correct card can show is
/// found, not the first alone.
pub fn judge_all(
    spec: &Spec,
    dir: &Path,
    exchanges: &[Exchange],
    names: &[String],
    bound: Duration,
) -> Result<Verdict, String> {
    let mut left_out = std::collections::BTreeSet::new();
    let mut v = Verdict {
        faults: Vec::new(),
        readings: Vec::new(),
        profiles: Vec::new(),
        explained: false,
        undecided: None,
        passes: Vec::new(),
    };
    loop {
        let kept: Vec<Exchange> = exchanges.iter().filter(|e| !left_out.contains(&e.unit)).cloned().collect();
        if kept.is_empty() {
            v.undecided = Some("every unit had a fault: nothing is left to judge the readings on".into());
            return Ok(v);
        }
        let start = Instant::now();
        let outcome = judge(spec, dir, &kept, bound)?;
        v.passes.push((left_out.len(), start.elapsed().as_secs_f64()));
        match outcome {
            Pass::Explained { readings, profiles } => {
                v.readings = readings;
                v.profiles = profiles;
                v.explained = true;
                return Ok(v);
            }
            Pass::Undecided(why) => {
                v.undecided = Some(why);
                return Ok(v);
            }
            Pass::Fault(unit, fault) => {
                let name = names.get(unit).cloned().unwrap_or_else(|| "the reset that starts the campaign".into());
                v.faults.push(Found { unit, unit_name: name, fault });
                if unit == super::campaign::START || !left_out.insert(unit) {
                    v.undecided = Some("the fault lies where leaving it out leaves no log to judge".into());
                    return Ok(v);
                }
            }
        }
    }
}

enum Pass {
    Explained { readings: Vec<ReadingVerdict>, profiles: Vec<(String, bool, bool)> },
    Fault(usize, Fault),
    Undecided(String),
}

/// One pass of the search over `exchanges`, written to `dir` as a host log.
fn judge(spec: &Spec, dir: &Path, exchanges: &[Exchange], bound: Duration) -> Result<Pass, String> {
    let (text, map) = segment_text("pmacwd probe: the campaign's log, without the units that had a fault", exchanges);
    let path = dir.join("judged.log");
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    let import = ImportAs {
        configuration: None,
        format: Some(LogFormat::HostLog),
        placement: Placement::AtReads,
        host_time_limit: Some(bound),
        deadline: Some(Instant::now() + bound),
        card_i40: None,
    };
    let judged = report::explain_as(spec, &path, import);
    let _ = std::fs::remove_file(&path);
    let r = match judged {
        Ok(r) => r,
        Err(e) if e.message.starts_with(pmacwd_capture::explain::search::OUT_OF_TIME) => {
            return Ok(Pass::Undecided(format!(
                "the search ran past its bound of {} s (--judge-seconds)",
                bound.as_secs()
            )));
        }
        // Not a log the importer reads (a reply it cannot pair): no verdict, said with the
        // reason, never a fault.
        Err(e) => return Ok(Pass::Undecided(format!("not judged: {}", e.message))),
    };
    if r.host_time_unfinished {
        return Ok(Pass::Undecided(format!(
            "placed by host time, the search ran past its bound of {} s (--judge-seconds)",
            bound.as_secs()
        )));
    }
    if r.explained() {
        return Ok(Pass::Explained { readings: r.readings, profiles: r.profiles });
    }
    if r.undecided() {
        return Ok(Pass::Undecided(r.untimed.unwrap_or_default()));
    }
    let death = r
        .lanes
        .iter()
        .filter_map(|l| l.death.as_ref())
        .max_by_key(|d| d.event)
        .cloned()
        .ok_or("a capture no lane explains without a lane's failure")?;
    // The judged file's line numbers count from 1; `map` from 0.
    let log_line = map.get(death.line.saturating_sub(1)).copied().unwrap_or(0);
    let at = exchanges
        .iter()
        .find(|e| e.log_line == log_line || e.log_line + 1 == log_line)
        .or(exchanges.last())
        .ok_or("an empty log")?;
    Ok(Pass::Fault(
        at.unit,
        Fault {
            check: classify(at, &death.what, &death.expected, &death.observed),
            line: at.log_line,
            command: at.line.clone(),
            reply: at.reply.log_text(),
            what: death.what,
            card: death.expected,
            correct: death.observed,
        },
    ))
}

/// Which behaviour a fault at exchange `at` is of, from what the card answered (`card`) where
/// a correct card could have answered `model`:
/// - on a line with `???` and the words it reports (X:$6, Y:$6, answered at one instant),
///   `???` disagreeing with them is the status words' fault;
/// - a bit 22 the card shows clear where every correct card still has it set is bit 22's;
/// - in a unit of its own (the trip) the unit's check;
/// - on a poll line, the command whose answer failed;
/// - else the check the exchange was sent for.
fn classify(at: &Exchange, what: &str, card: &str, model: &str) -> &'static Check {
    let commands: Vec<&str> = at.line.split_whitespace().collect();
    let answers: &[String] = match &at.reply {
        Reply::Answers(a) if a.len() == commands.len() => a,
        _ => &[],
    };
    let answer_of = |c: &str| commands.iter().position(|x| *x == c).and_then(|i| answers.get(i));
    if let (Some(x6), Some(y6)) = (answer_of("RHX:$6"), answer_of("RHY:$6")) {
        let words = format!("{x6}{y6}");
        let differs: Vec<u64> = commands
            .iter()
            .zip(answers)
            .filter(|(c, a)| **c == "???" && a.len() == 12 && **a != words)
            .filter_map(|(_, a)| Some(u64::from_str_radix(a, 16).ok()? ^ u64::from_str_radix(&words, 16).ok()?))
            .collect();
        if !differs.is_empty() {
            // Only bit 22, cleared by a `???` earlier on the line: bit 22 is not sticky.
            let bit22 = 1u64 << (22 + 24);
            let only_22 =
                differs.iter().all(|d| *d == bit22) && u64::from_str_radix(&words, 16).is_ok_and(|w| w & bit22 != 0);
            return if only_22 { &BIT22 } else { &STATUS };
        }
    }
    let hex = |t: &str| {
        let t = t.trim();
        (t.len() == 6 || t.len() == 12).then(|| u64::from_str_radix(t, 16).ok()).flatten().map(|v| (v, t.len()))
    };
    if let (Some((c, n)), Some((m, k))) = (hex(card), hex(model)) {
        let bit = if n == 12 { 1u64 << (22 + 24) } else { 1 << 22 };
        let status = answer_of("???").is_some() || answer_of("RHX:$6").is_some();
        if status && n == k && m & bit != 0 && c & bit == 0 {
            return &BIT22;
        }
    }
    if std::ptr::eq(at.check, &TRIP) || commands.len() < 2 {
        return at.check;
    }
    if what.starts_with("X:$25") {
        return &WATCHDOG_MINIMUM;
    }
    let failed: Vec<&str> =
        commands.iter().zip(answers).filter(|(_, a)| a.as_str() == card.trim()).map(|(c, _)| *c).collect();
    for (command, check) in [
        ("RHX:$25", &WATCHDOG_MINIMUM),
        ("RHY:$25", &WATCHDOG_COUNTER),
        ("???", &STATUS),
        ("RHX:$6", &STATUS),
        ("RHY:$6", &STATUS),
        ("RHX:$0", &SERVO_COUNTER),
    ] {
        if failed.contains(&command) {
            return check;
        }
    }
    at.check
}
