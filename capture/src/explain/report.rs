//! The replay verdict: which combinations of readings explain a capture, what each reading's
//! options come to, one explanation, and, when the card fell silent, the diagnosis.

use super::lanes::{self, READINGS};
use super::search::{self, Death, Lane, Tolerances};
use super::share;
use super::witness::{self, Witness};
use crate::replay::ImportAs;
use crate::replay::Source;
use pmacwd_model::controller::TripCause;
use pmacwd_specs::{Position, Spec, SpecError};
use std::path::{Path, PathBuf};

/// What a capture says about one option of one reading.
#[derive(Clone, Debug)]
pub enum OptionVerdict {
    /// Some combination choosing it explains the capture: how many lanes do.
    Supported(usize),
    /// No combination choosing it explains the capture; the one that lasted longest died here.
    RuledOut(Death),
}

#[derive(Clone, Debug)]
pub struct ReadingVerdict {
    pub reading: &'static str,
    pub options: Vec<(&'static str, OptionVerdict)>,
    /// Why the capture cannot judge this reading, if it cannot (both options then share lanes).
    pub not_exercised: Option<&'static str>,
}

#[derive(Clone, Debug)]
pub struct LaneSummary {
    pub label: String,
    pub combinations: usize,
    pub death: Option<Death>,
    pub candidates_end: usize,
    pub candidates_peak: usize,
    /// The card's values of what UM p.215 states approximately: those that explain the
    /// capture, or, for a lane that fails, those it lasted longest under.
    pub tolerances: Tolerances,
    /// How many cards within the bands were searched (1: the stated values explained it).
    pub tolerances_tried: usize,
    /// How many cards the bands admit in all.
    pub tolerances_admitted: usize,
    /// Not searched: the explanation found under the lane named here reproduces the capture
    /// under this lane's readings too (`share`).
    pub shown_by: Option<String>,
}

/// Why a card that fell silent may have tripped.
#[derive(Clone, Debug, Default)]
pub struct Diagnosis {
    pub possible: Vec<String>,
    pub ruled_out: Vec<String>,
}

pub struct Report {
    pub file: PathBuf,
    pub description: String,
    pub configuration: String,
    pub events: u64,
    pub lanes: Vec<LaneSummary>,
    pub readings: Vec<ReadingVerdict>,
    /// The named profiles of `profiles.yaml` the capture was judged under: (name, default,
    /// explains).
    pub profiles: Vec<(String, bool, bool)>,
    /// The lane the explanation is for, and the explanation.
    pub witness: Option<(String, Witness)>,
    /// The named profiles whose readings the explanation's lane stands for.
    pub witness_profiles: Vec<String>,
    pub card: Option<pmacwd_specs::config::CardConfig>,
    pub diagnosis: Option<Diagnosis>,
    /// What a host log itself shows of each stretch the card did not answer, in its lines and
    /// host clock ([`super::silences`]); empty for a trace.
    pub silences: super::silences::Silences,
    /// The importer's warning when the log cannot be timed (no X:$0 reads to place its
    /// commands in time): then every command is at one instant, and a capture that no card
    /// explains so is undecided, not impossible (issue 36).
    pub untimed: Option<String>,
    /// Where the commands between X:$0 reads were placed for this verdict.
    pub placement: crate::import::Placement,
    /// When placing them at the reads' instants explained nothing and host time was tried:
    /// where the first placement failed, in words.
    pub at_reads_failed: Option<String>,
    /// Whether the capture is a stamped host log whose commands host time places apart from
    /// the X:$0 reads before them (more than about 10 ms; or a log without two reads).
    pub placed_apart: bool,
    /// The search placing the log by host time ran past its limit: the verdict is undecided.
    pub host_time_unfinished: bool,
    /// The log never reads I40: the values tried and the one that explains it
    /// ([`super::unknown`]).
    pub i40_open: Option<super::unknown::OpenI40>,
    /// What the steps alone show that no card shows, whatever its timing, tolerances, I40 or
    /// placement ([`super::refute::refuted`]), when no card explained the capture: the
    /// verdict is then decided without searching those.
    pub refuted: Option<String>,
    /// Whether [`Report::refuted`] was found before any search, so that no lane was searched.
    pub refuted_unsearched: bool,
}

impl Report {
    pub fn explained(&self) -> bool {
        self.lanes.iter().any(|l| l.death.is_none())
    }

    /// Not explained, but only because the log cannot be timed: no verdict either way.
    pub fn undecided(&self) -> bool {
        !self.explained() && self.untimed.is_some() && self.refuted.is_none()
    }
}

const STARVED: &str = "the background stopped completing (PLC 0 or other RTI tasks overrunning, a servo load \
                       beyond the cycle, or one background task too long), the watchdog counter ran out and the \
                       strobe stopped (UM p.215)";
const UNDERVOLTAGE: &str = "the logic supply dipped below its minimum, about 4.75 V (UM p.215)";

/// Judges the capture at `path`; a host log is imported under `import_configuration` (a
/// trace names its own configuration).
pub fn explain(spec: &Spec, path: &Path, import_configuration: Option<&str>) -> Result<Report, SpecError> {
    explain_as(spec, path, import_configuration.into())
}

/// Judges the capture at `path`; a log is imported as `import_configuration` says (its
/// configuration and format).
///
/// A stamped log is judged first with the commands between X:$0 reads at the reads' instants
/// (fast). If no correct card explains it so, and host time places some command more than
/// about 10 ms after the read before it, it is judged again with every exchange at its own
/// host time, and that verdict stands: a poll spread between reads (bit 12 flipping
/// between two `???` 0.1 s apart) is not called impossible for want of time the log shows
/// passed (issue 36).
///
/// A log under the `host-log` configuration that never reads I40 leaves the card's I40 open:
/// the values the log admits are tried ([`super::unknown`]).
pub fn explain_as(spec: &Spec, path: &Path, import_configuration: ImportAs<'_>) -> Result<Report, SpecError> {
    if let Some(v) = import_configuration.card_i40 {
        let source = Source::open_with(spec, path, import_configuration)?;
        if let Some(read) = source.card().and_then(|c| c.i40).filter(|read| *read != v) {
            return Err(SpecError::whole_file(
                path,
                format!("--i40 {v}: the capture itself says the card's I40 is {read} (a read before any write, or its card: header)"),
            ));
        }
    }
    match super::unknown::evidence(spec, path, import_configuration)? {
        Some(e) => explain_open_i40(spec, path, import_configuration, &e),
        None => explain_timed(spec, path, import_configuration),
    }
}

/// Judges a capture whose I40 the log leaves open, trying the values it admits one after the
/// other ([`super::unknown`]): the first that explains it is the verdict; none explaining, the
/// report that came furthest, impossible when the values stand for all (or the capture shows
/// what no card shows whatever its I40), else undecided.
fn explain_open_i40(
    spec: &Spec,
    path: &Path,
    import: ImportAs<'_>,
    e: &super::unknown::Evidence,
) -> Result<Report, SpecError> {
    use super::unknown::OpenI40;
    let (tries, complete) = e.values(spec);
    let mut last: Option<Report> = None;
    let mut tried = Vec::new();
    for v in tries {
        tried.push(v);
        let mut r = explain_timed(spec, path, ImportAs { card_i40: Some(i64::from(v)), ..import })?;
        let explained = r.explained();
        r.i40_open = Some(OpenI40 {
            tried: tried.clone(),
            explaining: explained.then_some(v),
            complete,
            highest_read: e.highest_read(),
            refuted: None,
        });
        if explained {
            return Ok(r);
        }
        // The report kept is the one that came furthest.
        let latest = |r: &Report| r.lanes.iter().filter_map(|l| l.death.as_ref().map(|d| d.event)).max();
        if last.as_ref().is_none_or(|l| latest(&r) > latest(l) || (r.undecided() && !l.undecided())) {
            last = Some(r);
        } else if let Some(l) = &mut last {
            l.i40_open = r.i40_open;
        }
    }
    let Some(mut r) = last else {
        return Err(SpecError::whole_file(path, "no value of I40 in its range is admitted by what the log reads"));
    };
    if !complete {
        let refuted = super::refute::refutation(spec, path, import)?;
        if let Some(o) = &mut r.i40_open {
            o.complete = refuted.is_some();
            o.refuted = refuted;
        }
    }
    if !r.i40_open.as_ref().is_some_and(|o| o.complete) && r.untimed.is_none() {
        let tried = r.i40_open.as_ref().map(|o| o.tried.clone()).unwrap_or_default();
        r.untimed = Some(format!(
            "warning: the log does not read I40 (the card's own, SRM p.57): no card with I40 in {} explains it, \
             and the other values the log admits were not searched; read I40 in the log (docs/capturing.md) or \
             give the card's value with --i40",
            super::unknown::list(&tried)
        ));
    }
    Ok(r)
}

/// [`explain_as`] with the card as the capture (and `--i40`) says it: at the reads' instants,
/// then by host time.
pub fn explain_timed(spec: &Spec, path: &Path, import_configuration: ImportAs<'_>) -> Result<Report, SpecError> {
    use crate::import::Placement;
    // Decided by the steps alone: no card, no placement in time can change it, so nothing is
    // searched; every lane dies at its line.
    let refuted = super::refute::refuted(spec, path, import_configuration)?;
    let mut first = explain_placed(spec, path, import_configuration, refuted.as_ref())?;
    if first.explained() {
        return Ok(first);
    }
    first.refuted = refuted.map(|r| r.why);
    if first.refuted.is_some() || import_configuration.placement == Placement::HostTime || !first.placed_apart {
        return Ok(first);
    }
    let failed = first
        .lanes
        .iter()
        .filter_map(|l| l.death.as_ref())
        .max_by_key(|d| d.event)
        .map(|d| format!("line {}: {}: expected {}, observed {}", d.line, d.what, d.expected, d.observed))
        .unwrap_or_default();
    let deadline = import_configuration.host_time_limit.map(|l| std::time::Instant::now() + l);
    let second =
        explain_placed(spec, path, ImportAs { placement: Placement::HostTime, deadline, ..import_configuration }, None);
    let mut second = match second {
        Err(e) if e.message.starts_with(search::OUT_OF_TIME) => {
            // No verdict either way: at the reads' instants it fails, by host time it did not
            // finish. Undecided, with both said.
            let mut first = first;
            first.untimed = Some(format!(
                "warning: with the commands between X:$0 reads at the reads' instants no card fits ({failed}); {} \
                 after {} s: placed so, the log is not judged (raise --host-time-seconds)",
                e.message,
                import_configuration.host_time_limit.map_or(0, |l| l.as_secs())
            ));
            first.at_reads_failed = Some(failed);
            first.host_time_unfinished = true;
            return Ok(first);
        }
        other => other?,
    };
    second.at_reads_failed = Some(failed);
    // Without two X:$0 reads a restart cannot be seen: a log host time alone cannot explain
    // stays undecided, as it was with its commands at one instant.
    if second.untimed.is_none() && !second.explained() {
        second.untimed = first.untimed;
    }
    Ok(second)
}

/// Every lane of `defs` dead at the observation the steps alone refute ([`super::refute`]),
/// none searched: no card of the bands, no placement in time gets past it.
fn refuted_lanes(
    spec: &Spec,
    path: &Path,
    card: Option<&pmacwd_specs::config::CardConfig>,
    configuration: &str,
    defs: Vec<lanes::LaneDef>,
    r: &super::refute::Refuted,
) -> Result<share::Judged, SpecError> {
    let lanes = defs
        .into_iter()
        .map(|def| {
            let mut lane = search::Lane::new(spec, configuration, card, def, false, None)
                .map_err(|e| SpecError::whole_file(path, format!("configuration `{configuration}`: {}", e.message)))?;
            lane.cands.clear();
            lane.peak = 0;
            lane.death = Some(search::Death {
                event: r.event,
                line: r.line,
                what: r.what.clone(),
                expected: r.expected.clone(),
                observed: r.observed.clone(),
                candidates: 0,
                whatever_the_card: true,
            });
            Ok(lane)
        })
        .collect::<Result<Vec<_>, SpecError>>()?;
    Ok(share::Judged { lanes, events: r.events, witnesses: Vec::new() })
}

/// Judges the capture as `import_configuration` places it: each lane of readings searched, or,
/// where the steps alone are `refuted`, each dead at that line unsearched.
fn explain_placed(
    spec: &Spec,
    path: &Path,
    import_configuration: ImportAs<'_>,
    refuted: Option<&super::refute::Refuted>,
) -> Result<Report, SpecError> {
    let source = Source::open_with(spec, path, import_configuration)?;
    let configuration = source.configuration().to_string();
    let description = source.description().to_string();
    let profiles = source.profiles(spec, path)?;
    let card = source.card_as(&import_configuration);
    let (observed, untimed, placed_apart, assigns_out_of_range) = scan(spec, source)?;
    if !spec.check.configurations.contains_key(&configuration) {
        return Err(SpecError::at(
            path,
            Position { line: 1, column: 1 },
            format!(
                "no configuration named `{configuration}` in check.yaml (configurations: {})",
                spec.check.configurations.keys().cloned().collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    let all = profiles.len() == spec.profiles.all().len();
    let defs = lanes::lanes(spec, &configuration, if all { None } else { Some(&profiles) }, assigns_out_of_range)?;
    // Lanes another lane's explanation reproduces are not searched (`share`).
    let default = lanes::options_of(&spec.profiles.default_profile().choices);
    let share::Judged { lanes: done, events, witnesses } = match refuted {
        Some(r) => refuted_lanes(spec, path, card.as_ref(), &configuration, defs, r)?,
        None => share::judge(spec, path, import_configuration, defs, default)?,
    };

    let summaries: Vec<LaneSummary> = done
        .iter()
        .map(|l| LaneSummary {
            label: lanes::label(&l.def.choices),
            combinations: l.def.combinations.len(),
            death: l.death.clone(),
            candidates_end: l.cands.len(),
            candidates_peak: l.peak,
            tolerances: l.tolerances,
            tolerances_tried: l.tolerances_tried,
            tolerances_admitted: l.tolerances_admitted,
            shown_by: l.shown_by.clone(),
        })
        .collect();
    let readings = READINGS
        .iter()
        .enumerate()
        .map(|(r, (reading, options))| {
            let options = options
                .iter()
                .enumerate()
                .filter(|(o, _)| done.iter().any(|l| l.def.combinations.iter().any(|c| c[r] == *o)))
                .map(|(o, name)| {
                    let choosing = || done.iter().filter(move |l| l.def.combinations.iter().any(|c| c[r] == o));
                    let alive = choosing().filter(|l| l.alive()).count();
                    let v = if alive > 0 {
                        OptionVerdict::Supported(alive)
                    } else {
                        let latest =
                            choosing().filter_map(|l| l.death.clone()).max_by_key(|d| d.event).expect("a lane died");
                        OptionVerdict::RuledOut(latest)
                    };
                    (*name, v)
                })
                .collect();
            ReadingVerdict {
                reading,
                options,
                not_exercised: lanes::not_exercised(spec, &configuration, r, assigns_out_of_range),
            }
        })
        .collect();
    let named = profiles
        .iter()
        .map(|p| {
            let o = lanes::options_of(&p.choices);
            let explains = done.iter().any(|l| l.alive() && l.def.combinations.contains(&o));
            (p.name.clone(), p.name == spec.profiles.default_profile().name, explains)
        })
        .collect();
    let diagnosis = diagnose(&done, observed);
    let silences = match import_configuration.format.map_or_else(|| crate::import::looks_like(path), |f| Ok(Some(f)))? {
        Some(format) => super::silences::silences(path, format)?,
        None => super::silences::Silences::default(),
    };

    // The explanation: the default profile's lane if it explains, else the first that does,
    // searched again with its choices recorded (unless round 1 of `share` built it).
    let chosen = done
        .iter()
        .find(|l| l.alive() && l.def.combinations.contains(&default))
        .or_else(|| done.iter().find(|l| l.alive()))
        .map(|l| (l.def.clone(), l.tolerances));
    let witness_profiles: Vec<String> = chosen
        .as_ref()
        .map(|(def, _)| {
            profiles
                .iter()
                .filter(|p| def.combinations.contains(&lanes::options_of(&p.choices)))
                .map(|p| p.name.clone())
                .collect()
        })
        .unwrap_or_default();
    let witness = match chosen {
        Some((def, tolerances)) => {
            let label = lanes::label(&def.choices);
            match witnesses.into_iter().find(|(l, w)| *l == label && w.tolerances.unwrap_or(tolerances) == tolerances) {
                Some(built) => Some(built),
                None => Some(witness::witness_for(spec, path, import_configuration, def, tolerances)?),
            }
        }
        None => None,
    };
    Ok(Report {
        file: path.to_path_buf(),
        description,
        configuration,
        events,
        lanes: summaries,
        readings,
        profiles: named,
        witness,
        witness_profiles,
        card,
        diagnosis,
        silences,
        untimed,
        placement: import_configuration.placement,
        at_reads_failed: None,
        placed_apart,
        host_time_unfinished: false,
        i40_open: None,
        refuted: None,
        refuted_unsearched: refuted.is_some(),
    })
}

/// When some explaining card is tripped at the end: every cause that remains possible.
/// What the capture itself shows, read once before the search: whether a `???` reply shows RTI
/// re-entry (bit 22, SRM p.289), which the diagnosis may call observed, as against what the
/// search chose in the unseen gaps; and, for a host log, the importer's timing warning.
/// Reads the whole capture once: whether a `???` reply shows bit 22, the importer's timing
/// warning, whether it is a stamped host log, and whether it assigns I8, I40 or I41 a value
/// outside its range (only then are both options of `out_of_range_assignment` searched,
/// UM p.243).
fn scan(spec: &Spec, mut source: Source) -> Result<(bool, Option<String>, bool, bool), SpecError> {
    use pmacwd_specs::status::WordId;
    use pmacwd_specs::vocab::reply_text::{self, StatusReply};
    let bit22 = spec.status.bit("rti_reentry");
    let mut seen = false;
    let mut out_of_range = false;
    while let Some((_, step)) = source.next_step()? {
        // An unanswered assignment may still have been processed (`Controller::unanswered`).
        if let pmacwd_trace::TraceEvent::Model(pmacwd_specs::vocab::event::Event::Command(c))
        | pmacwd_trace::TraceEvent::Unanswered { command: c, .. } = &step.event
        {
            out_of_range |= lanes::assigns_out_of_range(spec, c);
        }
        seen |= step.expect.status_set.iter().any(|n| n == "rti_reentry");
        if let (Some((word, bit)), Some(Ok(StatusReply::Words { x, y }))) =
            (bit22, step.expect.reply.as_deref().map(reply_text::decode))
        {
            let w = match word {
                WordId::X => x,
                WordId::Y => y,
            };
            seen |= w & (1 << bit) != 0;
        }
    }
    let (untimed, stamped) = match &source {
        Source::HostLog(stream) => (
            stream.summary().and_then(|s| s.timing_warning()),
            stream.summary().is_some_and(|s| s.spread_between_reads()),
        ),
        _ => (None, false),
    };
    Ok((seen, untimed, stamped, out_of_range))
}

fn diagnose(lanes: &[Lane], rti_reentry_observed: bool) -> Option<Diagnosis> {
    let alive: Vec<&Lane> = lanes.iter().filter(|l| l.alive()).collect();
    let tripped: Vec<_> = alive.iter().flat_map(|l| l.cands.iter()).filter(|c| c.card.tripped()).collect();
    if tripped.is_empty() {
        return None;
    }
    let mut d = Diagnosis::default();
    let has = |cause: TripCause| tripped.iter().any(|c| c.card.trip == Some(cause));
    if has(TripCause::StrobeTimeout) {
        let overran =
            tripped.iter().any(|c| c.card.trip == Some(TripCause::StrobeTimeout) && c.card.status.rti_reentry);
        let mut s = STARVED.to_string();
        // Only what the log shows is called seen; the search's own choice in an unseen gap is
        // said to be its choice (issue 29).
        if rti_reentry_observed {
            s.push_str("; the log's `???` replies show RTI overruns (bit 22), which points at PLC 0 or move planning");
        } else if overran {
            s.push_str(
                "; in the explanation the search chose, RTI overruns (bit 22) came before the trip, which no `???` \
                 reply of the log shows",
            );
        }
        d.possible.push(s);
    } else {
        // UM p.236: host commands are processed in the background, so a background that stops
        // completing answers nothing from that moment, and the counter runs out only later: a
        // card silent at the end may be starving whenever its silence began (issue 36). The
        // search has that rule (`Controller::unanswered`), but a host log times a silence
        // only as well as its stamps do: the diagnosis names what the explanations show and
        // rules out nothing they do not.
        d.possible.push(format!(
            "{STARVED}: not in the explanations the search found; host commands are processed in the \
             background (UM p.236), so a starved background answers nothing from the moment it stops \
             completing and trips only when the counter has run out"
        ));
    }
    if has(TripCause::Undervoltage) {
        d.possible.push(format!("{UNDERVOLTAGE}: a host log cannot rule it out"));
    }
    if alive.iter().flat_map(|l| l.cands.iter()).any(|c| !c.card.tripped()) {
        d.possible.push(
            "no trip at all: the card may still run, silent only while its background is starved (UM p.236), \
             or nothing after this point shows it silent"
                .into(),
        );
    }
    Some(d)
}

/// The card's own values of what UM p.215 states approximately, when the stated ones do not
/// explain the capture.
fn tolerances_text(t: &Tolerances, lane: Option<&LaneSummary>) -> String {
    let tried = lane.map_or(String::new(), |l| {
        format!(" ({} of the {} cards the bands admit searched)", l.tolerances_tried, l.tolerances_admitted)
    });
    let pass = t.checksum_pass_cycles;
    let passes = if t.free_area {
        "checksum passes of a length of its own (no length of 1 or 2 background cycles explains it: the area bit \
         12 shows is taken from the log at each read, below)"
            .to_string()
    } else {
        format!(
            "checksum passes of {} background cycles (firmware) and {} (user program)",
            pass.firmware, pass.user_program
        )
    };
    format!(
        "the card's own tolerances: a hardware delay of {} servo cycles, a supply threshold of {} mV and \
         {passes}; UM p.215 gives the strobe minimum and the supply minimum only approximately and UM p.217 no \
         pass length, and the stated figures do not explain the capture, these do (within the bands of \
         watchdog.yaml){tried}",
        t.hardware_delay_cycles, t.supply_min_millivolts
    )
}

fn option_text(o: &str, v: &OptionVerdict) -> String {
    match v {
        OptionVerdict::Supported(n) => {
            // A lane stands for every combination its readings cannot tell apart (`lanes`).
            format!("{o}: supported ({n} lane{} explain the capture)", if *n == 1 { "" } else { "s" })
        }
        OptionVerdict::RuledOut(d) => format!(
            "{o}: RULED OUT (no combination with it explains the capture; the last to fail failed at event {} \
             (line {}): {}: expected {}, observed {})",
            d.event, d.line, d.what, d.expected, d.observed
        ),
    }
}

pub fn to_text(r: &Report) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "replay {}: {} events, configuration {}", r.file.display(), r.events, r.configuration);
    if let Some(w) = &r.untimed {
        let _ = writeln!(s, "  {w}");
    }
    if let (Some(failed), false) = (&r.at_reads_failed, r.host_time_unfinished) {
        let _ = writeln!(
            s,
            "  placed by host time: with the commands between X:$0 reads at the reads' instants no card fit \
             ({failed}); each exchange is placed at its own host time below"
        );
    }
    let _ = writeln!(s, "  {}", r.description.split_whitespace().collect::<Vec<_>>().join(" "));
    if let Some(o) = &r.i40_open {
        let highest = o.highest_read.map_or(String::new(), |h| format!("; the highest Y:$25/X:$25 read is {h}"));
        let _ = match o.explaining {
            Some(v) => writeln!(
                s,
                "  I40: the log does not read it (the card's own, SRM p.57): a card with I40 = {v} explains it \
                 (tried {}{highest})",
                super::unknown::list(&o.tried)
            ),
            None => writeln!(
                s,
                "  I40: the log does not read it (the card's own, SRM p.57): no card with I40 in {} explains it{}{highest}",
                super::unknown::list(&o.tried),
                match (&o.refuted, o.complete) {
                    (Some(why), _) => format!(", nor with any other: {why}"),
                    (None, true) => ", and these stand for every value the log admits".to_string(),
                    (None, false) => String::new(),
                }
            ),
        };
    }
    if let Some(why) = &r.refuted {
        let _ = writeln!(s, "  no card, whatever its timing: {why}");
    }
    let alive = r.lanes.iter().filter(|l| l.death.is_none()).count();
    let combinations: usize = r.lanes.iter().map(|l| l.combinations).sum();
    let _ = match &r.refuted_unsearched {
        true => writeln!(
            s,
            "lanes of readings: {} (standing for {combinations} combinations); none searched: the steps alone rule \
             every one out",
            r.lanes.len()
        ),
        false => writeln!(
            s,
            "lanes of readings searched: {} (standing for {combinations} combinations); {} explain the capture",
            r.lanes.len(),
            if alive == 0 { "none".to_string() } else { alive.to_string() }
        ),
    };
    s.push_str("readings:\n");
    for rv in &r.readings {
        match rv.not_exercised {
            Some(why) => {
                let _ = writeln!(s, "  {}: not exercised: {why}", rv.reading);
            }
            None => {
                let supported = rv.options.iter().filter(|(_, v)| matches!(v, OptionVerdict::Supported(_))).count();
                let state = match (supported, rv.options.len()) {
                    (0, _) => "no option explains the capture",
                    (1, 2) => "decided",
                    (1, _) => "only this option was judged",
                    _ => "undecided: both options explain the capture",
                };
                let _ = writeln!(s, "  {}: {state}", rv.reading);
                for (o, v) in &rv.options {
                    let _ = writeln!(s, "      {}", option_text(o, v));
                }
            }
        }
    }
    if !r.profiles.is_empty() {
        s.push_str("named profiles:\n");
        for (name, default, explains) in &r.profiles {
            let tag = if *default { " (default)" } else { "" };
            let _ = writeln!(
                s,
                "  {:<30} {}",
                format!("{name}{tag}"),
                if *explains { "explains" } else { "does not explain" }
            );
        }
    }
    if let Some((label, w)) = &r.witness {
        let _ = writeln!(s, "explanation (readings: {label}):");
        let cpu = ["DSP56303", "DSP56309", "DSP56311", "DSP56321"][usize::from(w.cpu & 3)];
        if w.cpu_decided {
            let _ = writeln!(s, "  the card's CPU is a {cpu} (bits 21 of ???, SRM p.289)");
        }
        if let Some(t) = &w.tolerances {
            let _ = writeln!(s, "  {}", tolerances_text(t, r.lanes.iter().find(|l| &l.label == label)));
        }
        if w.story.is_empty() {
            s.push_str("  a background cycle completed in every gap soon enough: nothing unusual happened unseen\n");
        }
        for line in &w.story {
            let _ = writeln!(s, "  {line}");
        }
        match &w.checked {
            Some(Ok(n)) => {
                let _ = writeln!(
                    s,
                    "  checked: this behaviour, run on the model, reproduces all {n} observations ({} steps; \
                     --witness FILE writes it as a trace)",
                    w.steps
                );
            }
            Some(Err(e)) => {
                let _ = writeln!(s, "  WARNING: the explanation does not reproduce the capture on the model: {e}");
            }
            None => {}
        }
    }
    if !r.silences.shown.is_empty() {
        s.push_str("what the log shows of the card's silences (its own lines and clock, not the search's choices):\n");
        for x in &r.silences.shown {
            let _ = writeln!(s, "  {}", x.text());
        }
        if r.silences.more > 0 {
            let _ = writeln!(s, "  and {} more silences", r.silences.more);
        }
    }
    if let Some(d) = &r.diagnosis {
        s.push_str("diagnosis: the card is silent at the end; why it tripped (UM p.215, \"Diagnosing Cause of Watchdog Timer Trip\"):\n");
        for p in &d.possible {
            let _ = writeln!(s, "  possible: {p}");
        }
        for p in &d.ruled_out {
            let _ = writeln!(s, "  {p}");
        }
    }
    if alive == 0 {
        s.push_str("why not:\n");
        let mut deaths: Vec<&LaneSummary> = r.lanes.iter().collect();
        deaths.sort_by_key(|l| std::cmp::Reverse(l.death.as_ref().map(|d| d.event)));
        // Refuted before any search: every lane died at the one observation.
        let shown = if r.refuted_unsearched { 0 } else { 3 };
        if let Some(d) = deaths.first().and_then(|l| l.death.as_ref()).filter(|_| r.refuted_unsearched) {
            let _ = writeln!(
                s,
                "  every lane: event {} (line {}): {}: expected {}, observed {} (not searched: no card gets past it, \
                 whatever its timing, tolerances and I40; above)",
                d.event, d.line, d.what, d.expected, d.observed
            );
        }
        for l in deaths.iter().take(shown) {
            if let Some(d) = &l.death {
                let cards = match l.tolerances_admitted {
                    _ if d.whatever_the_card => "; no card of the bands gets past it, whatever its timing: no state of \
                                                 the card gives this under these readings (SRM p.289, UM p.217)"
                        .to_string(),
                    0 | 1 => String::new(),
                    n => format!("; all {n} cards the bands of hardware delay and supply threshold admit were searched, none lasted longer"),
                };
                let _ = writeln!(
                    s,
                    "  {}: event {} (line {}): {}: expected {}, observed {} ({} candidate state{} before it{cards})",
                    l.label,
                    d.event,
                    d.line,
                    d.what,
                    d.expected,
                    d.observed,
                    d.candidates,
                    if d.candidates == 1 { "" } else { "s" }
                );
            }
        }
    }
    let _ = writeln!(
        s,
        "verdict: {}",
        if alive == 0 && r.refuted.is_some() {
            "no correct card explains this capture, under any combination of readings".to_string()
        } else if alive == 0 && r.host_time_unfinished {
            "undecided: no explanation places the commands between X:$0 reads at the reads' instants, and the \
             search placing them by host time did not finish in its time limit (--host-time-seconds)"
                .to_string()
        } else if alive == 0 && r.i40_open.as_ref().is_some_and(|o| !o.complete) {
            "undecided: the log does not read I40, and the values of I40 that were searched explain nothing; \
             whether a card with another I40 explains it was not searched (read I40 in the log, or give --i40)"
                .to_string()
        } else if alive == 0 && r.untimed.is_some() {
            "undecided: no explanation places every command at one instant, and the log has no servo counter \
             reads (X:$0) to place them in time; read RHX:$0 in every poll (docs/capturing.md)"
                .to_string()
        } else if alive == 0 {
            "no correct card explains this capture, under any combination of readings".to_string()
        } else {
            "explained: a correct card can produce this capture".to_string()
        }
    );
    s
}

fn silence_json(x: &super::silences::Silence) -> serde_json::Value {
    use super::silences::At;
    let at = |a: &At| serde_json::json!({"line": a.line, "host_time": a.ns.map(super::silences::clock)});
    serde_json::json!({
        "first_sent": at(&x.first_sent), "commands": x.first_commands, "gave_up": at(&x.gave_up), "lines": x.lines,
        "last_answer": x.last_answer.as_ref().map(at),
        "last_action": x.last_action.as_ref().map(|(c, a)| serde_json::json!({"command": c, "sent": at(a)})),
        "answered_again": x.answered_again.as_ref().map(at), "text": x.text(),
    })
}

fn death_json(d: &Death) -> serde_json::Value {
    serde_json::json!({"event": d.event, "line": d.line, "what": d.what, "expected": d.expected,
        "observed": d.observed, "candidates_before": d.candidates, "whatever_the_card": d.whatever_the_card})
}

pub fn to_json(r: &Report) -> String {
    let readings: serde_json::Map<String, serde_json::Value> = r
        .readings
        .iter()
        .map(|rv| {
            let opts: serde_json::Map<String, serde_json::Value> = rv
                .options
                .iter()
                .map(|(o, v)| {
                    let v = match v {
                        OptionVerdict::Supported(n) => serde_json::json!({"verdict": "supported", "explaining": n}),
                        OptionVerdict::RuledOut(d) => {
                            serde_json::json!({"verdict": "ruled_out", "last_failure": death_json(d)})
                        }
                    };
                    (o.to_string(), v)
                })
                .collect();
            (rv.reading.to_string(), serde_json::json!({"not_exercised": rv.not_exercised, "options": opts}))
        })
        .collect();
    let lanes: Vec<serde_json::Value> = r
        .lanes
        .iter()
        .map(|l| {
            serde_json::json!({"readings": l.label, "combinations": l.combinations, "explains": l.death.is_none(),
                "failure": l.death.as_ref().map(death_json), "candidates_end": l.candidates_end,
                "candidates_peak": l.candidates_peak, "shown_by": l.shown_by,
                "tolerances": {"hardware_delay_cycles": l.tolerances.hardware_delay_cycles,
                    "supply_min_millivolts": l.tolerances.supply_min_millivolts,
                    "checksum_pass_cycles": {"firmware": l.tolerances.checksum_pass_cycles.firmware,
                        "user_program": l.tolerances.checksum_pass_cycles.user_program},
                    "checksum_passes_own": l.tolerances.free_area,
                    "searched": l.tolerances_tried, "admitted": l.tolerances_admitted}})
        })
        .collect();
    let profiles: Vec<serde_json::Value> =
        r.profiles.iter().map(|(n, d, e)| serde_json::json!({"profile": n, "default": d, "explains": e})).collect();
    serde_json::json!({
        "file": r.file.display().to_string(), "events": r.events, "configuration": r.configuration,
        "explained": r.explained(), "undecided": r.undecided(),
        "placement": match r.placement { crate::import::Placement::AtReads => "at_reads", crate::import::Placement::HostTime => "host_time" },
        "at_reads_failed": r.at_reads_failed, "refuted": r.refuted, "refuted_unsearched": r.refuted_unsearched,
        "i40_open": r.i40_open.as_ref().map(|o| serde_json::json!({"tried": o.tried, "explaining": o.explaining,
            "complete": o.complete, "highest_read": o.highest_read, "refuted": o.refuted})),
        "readings": readings, "lanes": lanes, "profiles": profiles,
        "explanation": r.witness.as_ref().map(|(label, w)| serde_json::json!({
            "readings": label, "cpu_type": w.cpu, "cpu_type_decided": w.cpu_decided, "story": w.story,
            "trace_steps": w.steps,
            "observations_checked": match &w.checked { Some(Ok(n)) => serde_json::json!(n), _ => serde_json::Value::Null },
            "reproduces": matches!(w.checked, Some(Ok(_))),
            "lowest_counter_min": w.lowest_min,
            "card_tolerances": w.tolerances.map(|t| serde_json::json!({
                "hardware_delay_cycles": t.hardware_delay_cycles, "supply_min_millivolts": t.supply_min_millivolts,
                "checksum_pass_cycles": {"firmware": t.checksum_pass_cycles.firmware,
                    "user_program": t.checksum_pass_cycles.user_program},
                "checksum_passes_own": t.free_area})),
        })),
        "diagnosis": r.diagnosis.as_ref().map(|d| serde_json::json!({"possible": d.possible, "ruled_out": d.ruled_out})),
        "silences": r.silences.shown.iter().map(silence_json).collect::<Vec<_>>(),
        "silences_not_shown": r.silences.more,
    })
    .to_string()
}
