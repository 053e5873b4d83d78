//! Lanes shown by another lane's explanation instead of searched.
//!
//! Most readings change what the card does only where a capture may never go: the reset
//! value of I40 = 0 on a card whose I40 is 2,000, the latch of bit 9 on a card that never
//! overran, the strobe's stop at zero on a counter that never ran down. Under such a reading
//! the search repeats another lane's work step for step; a 10 Hz status poll placed by host
//! time was searched 64 times over for two outcomes. So the lanes are judged in two rounds:
//!
//! 1. the default profile's lane, and on the second core the lane that differs from it only
//!    in the meaning of bit 12 (the reading a status poll tells apart), are searched with their
//!    choices recorded, and each that explains the capture gives its explanation (the witness);
//! 2. every other lane is first given the explanations found (`witness::run`: the behaviour,
//!    run on the model from power-on under that lane's own readings and stated tolerances, as
//!    `pmacwd run` would, every observation compared). A lane none reproduces is searched: two
//!    at a time, recorded, when its meaning of bit 12 explained the capture in round 1, so that
//!    each that explains adds its explanation for the rest (a full-period detector's card trips
//!    later than a half-period one's, so a starvation trip's explanation is not the other's);
//!    together, as before, otherwise.
//!
//! Sound by construction: a lane counts as explained only by a behaviour of the model under its
//! own readings that reproduces every observation of the capture, which is what "explains"
//! means; a lane that is not shown so is searched, and only a search rules one out.
//!
//! What a shown lane does not have is every candidate at the end, only the explanation's. The
//! diagnosis of a card silent at the end lists the causes the candidates of the explaining
//! lanes have and rules none out (`report::diagnose`): a cause a shown lane's own search might
//! have found is not lost to a "ruled out".

use super::lanes::{LaneDef, READINGS};
use super::search::{self, Cand, Lane};
use super::witness::{self, Witness};
use crate::replay::{ImportAs, Source};
use pmacwd_specs::{Spec, SpecError};
use std::path::Path;

/// The lanes judged, in the order given, and what was built on the way.
pub struct Judged {
    pub lanes: Vec<Lane>,
    /// Events in the capture.
    pub events: u64,
    /// Explanations built in round 1, with the lane label they were found under: the report's
    /// explanation reuses the one of its lane.
    pub witnesses: Vec<(String, Witness)>,
}

/// Judges every lane of `defs` (see the module's text). `default`: the default profile's option
/// indices.
pub fn judge(
    spec: &Spec,
    path: &Path,
    import: ImportAs<'_>,
    defs: Vec<LaneDef>,
    default: [usize; super::lanes::READINGS_COUNT],
) -> Result<Judged, SpecError> {
    let probes = probes(&defs, default);
    if defs.len() <= probes.len() + 1 {
        let (lanes, events) = search_in_two(spec, path, import, defs, false)?;
        return Ok(Judged { lanes, events, witnesses: Vec::new() });
    }
    let mut slots: Vec<Option<Lane>> = (0..defs.len()).map(|_| None).collect();
    let mut witnesses: Vec<(String, Witness)> = Vec::new();
    let others: Vec<usize> = (0..defs.len()).filter(|i| !probes.contains(i)).collect();
    let events = search_recorded(spec, path, import, &defs, &probes, &others, &mut slots, &mut witnesses)?;
    let bit12 = READINGS.iter().position(|(name, _)| *name == "bit12_meaning").expect("a reading of lanes.rs");
    let explaining_bit12: Vec<usize> = probes
        .iter()
        .filter_map(|i| slots[*i].as_ref())
        .filter(|l| l.alive())
        .map(|l| super::lanes::options_of(&l.def.choices)[bit12])
        .collect();
    // Each lane not judged yet, shown by none of the explanations found so far, is searched.
    // Those whose meaning of bit 12 explained the capture in round 1 are searched two at a
    // time with their choices recorded, so that each that explains adds its explanation for
    // the rest (a full-period detector's card trips later than a half-period one's: a
    // starvation trip's explanation is not the other's); the others, which rarely explain,
    // together as before.
    let mut likely: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut unlikely = Vec::new();
    for (i, def) in defs.iter().enumerate() {
        if slots[i].is_none() {
            if explaining_bit12.contains(&super::lanes::options_of(&def.choices)[bit12]) {
                likely.push_back(i);
            } else {
                unlikely.push(i);
            }
        }
    }
    loop {
        let batch: Vec<usize> = (0..2).map_while(|_| likely.pop_front()).collect();
        if batch.is_empty() {
            break;
        }
        let pending: Vec<usize> = likely.iter().chain(unlikely.iter()).copied().collect();
        let before = witnesses.len();
        search_recorded(spec, path, import, &defs, &batch, &pending, &mut slots, &mut witnesses)?;
        likely.retain(|i| slots[*i].is_none());
        unlikely.retain(|i| slots[*i].is_none());
        // A pair that adds no explanation: the rest are searched together, below. Each
        // search reads the whole capture again, which on a day-long log costs more than
        // the pairs save (a day at 2 Hz: 23 s of CPU in pairs).
        if witnesses.len() == before {
            break;
        }
    }
    let rest: Vec<usize> = likely.into_iter().chain(unlikely).collect();
    let (searched, _) = search_in_two(spec, path, import, rest.iter().map(|i| defs[*i].clone()).collect(), false)?;
    for (i, lane) in rest.iter().zip(searched) {
        slots[*i] = Some(lane);
    }
    Ok(Judged { lanes: slots.into_iter().map(|l| l.expect("every lane judged")).collect(), events, witnesses })
}

/// Searches the lanes `which` of `defs` (one per thread) with their choices recorded, puts them
/// in `slots`, and adds the explanation of each that explains the capture to `witnesses`
/// (dropping the recorded histories after). The walk that checks each explanation also runs it
/// under the readings of every lane of `pending` not judged yet (the capture read once per
/// explanation, not once per lane): a lane one reproduces is shown by it. Returns the
/// capture's event count.
#[allow(clippy::too_many_arguments)]
fn search_recorded(
    spec: &Spec,
    path: &Path,
    import: ImportAs<'_>,
    defs: &[LaneDef],
    which: &[usize],
    pending: &[usize],
    slots: &mut [Option<Lane>],
    witnesses: &mut Vec<(String, Witness)>,
) -> Result<u64, SpecError> {
    let source = Source::open_with(spec, path, import)?;
    let card = source.card_as(&import);
    let name = source.configuration().to_string();
    drop(source);
    let mut shown = Vec::new();
    for &i in pending.iter().filter(|i| slots[**i].is_none()) {
        let lane = Lane::new(spec, &name, card.as_ref(), defs[i].clone(), false, None)
            .map_err(|e| SpecError::whole_file(path, format!("configuration `{name}`: {}", e.message)))?;
        shown.push((i, lane));
    }
    let cfgs: Vec<&pmacwd_specs::config::ModelConfig> = shown.iter().map(|(_, l)| &l.cfg).collect();
    // Each lane on a thread of its own, searched and then explained there: the two
    // explanations of round 1 are built at once (on a day-long log each walk takes seconds).
    type Found = Result<(Vec<(Lane, Option<(String, Witness)>, Vec<witness::RunResult>)>, u64), SpecError>;
    let explained = |lanes: Vec<LaneDef>| -> Found {
        let (searched, events) = search::search(spec, path, import, lanes, true)?;
        let mut out = Vec::new();
        for mut lane in searched {
            let (mut found, mut runs) = (None, Vec::new());
            if lane.alive() {
                let (label, w, theirs) = witness::of_lane(spec, path, import, &lane, &cfgs)?;
                if matches!(w.checked, Some(Ok(_))) {
                    found = Some((label, w));
                    runs = theirs;
                }
            }
            for c in &mut lane.cands {
                c.node = None;
            }
            lane.checkpoints.clear();
            out.push((lane, found, runs));
        }
        Ok((out, events))
    };
    let (done, events) = in_two(path, which.iter().map(|i| defs[*i].clone()).collect(), explained)?;
    let mut shown: Vec<Option<(usize, Lane)>> = shown.into_iter().map(Some).collect();
    for (i, (lane, found, runs)) in which.iter().zip(done) {
        if let Some((label, w)) = found {
            for (slot, run) in shown.iter_mut().zip(runs) {
                if let (Some(_), Ok((_, end))) = (slot.as_ref(), run) {
                    let (j, mut lane) = slot.take().expect("checked");
                    lane.cands = vec![Cand {
                        counter_lo: end.counter,
                        min_lo: end.counter_min,
                        card: end,
                        cpu: w.cpu,
                        node: None,
                    }];
                    lane.peak = 1;
                    lane.shown_by = Some(label.clone());
                    slots[j] = Some(lane);
                }
            }
            witnesses.push((label, w));
        }
        slots[*i] = Some(lane);
    }
    Ok(events)
}

/// Round 1's lanes, as indices into `defs`: the default profile's (else the first), and the one
/// that differs from it only in `bit12_meaning`, if the capture is judged under it.
fn probes(defs: &[LaneDef], default: [usize; super::lanes::READINGS_COUNT]) -> Vec<usize> {
    let holding = |o: [usize; super::lanes::READINGS_COUNT]| defs.iter().position(|d| d.combinations.contains(&o));
    let first = holding(default).unwrap_or(0);
    let bit12 = READINGS.iter().position(|(name, _)| *name == "bit12_meaning").expect("a reading of lanes.rs");
    let mut other = defs.get(first).map_or(default, |d| super::lanes::options_of(&d.choices));
    other[bit12] = 1 - other[bit12];
    match holding(other) {
        Some(second) if second != first => vec![first, second],
        _ => vec![first],
    }
}

/// Searches `defs` on two threads (one per core of the machines this runs on), in their order;
/// `record` keeps each candidate's history (then one lane to a thread: two at most).
pub fn search_in_two(
    spec: &Spec,
    path: &Path,
    import: ImportAs<'_>,
    defs: Vec<LaneDef>,
    record: bool,
) -> Result<(Vec<Lane>, u64), SpecError> {
    in_two(path, defs, |work| search::search(spec, path, import, work, record))
}

/// `work` on each half of `defs`, on two threads, the results in their order with the
/// capture's event count.
fn in_two<T: Send>(
    path: &Path,
    defs: Vec<LaneDef>,
    work: impl Fn(Vec<LaneDef>) -> Result<(Vec<T>, u64), SpecError> + Sync,
) -> Result<(Vec<T>, u64), SpecError> {
    if defs.is_empty() {
        return Ok((Vec::new(), 0));
    }
    let half = defs.len().div_ceil(2);
    let work = &work;
    let results: Vec<Result<(Vec<T>, u64), SpecError>> = std::thread::scope(|scope| {
        let started: Vec<_> = defs
            .chunks(half.max(1))
            .map(|chunk| {
                let part = chunk.to_vec();
                std::thread::Builder::new().spawn_scoped(scope, move || work(part)).map_err(|_| chunk.to_vec())
            })
            .collect();
        // In order; a thread that could not start leaves its lanes to this one.
        started
            .into_iter()
            .map(|s| match s {
                Ok(h) => h.join().unwrap_or_else(|_| Err(SpecError::whole_file(path, "a search thread panicked"))),
                Err(chunk) => work(chunk),
            })
            .collect()
    });
    let mut done = Vec::new();
    let mut events = 0;
    for r in results {
        let (items, n) = r?;
        done.extend(items);
        events = n;
    }
    Ok((done, events))
}
