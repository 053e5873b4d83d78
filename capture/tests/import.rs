//! `pmacwd import`: what each situation in a host log becomes (docs/capturing.md), and that
//! every malformed log is refused with its file, line and column rather than guessed at.

use pmacwd_capture::import::{import, Imported};
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::SpecError;
use pmacwd_trace::{Step, TraceEvent};
use std::path::Path;

/// A log whose card reads I10 = 8388607: a 1000 Hz servo clock, one cycle per millisecond.
const KHZ: &str = "> I10\n< 8388607\n";

fn ok(log: &str) -> Imported {
    import(Path::new("s.log"), log, "i40-zero").unwrap_or_else(|e| panic!("{e}\n{log}"))
}

fn err(log: &str) -> SpecError {
    import(Path::new("s.log"), log, "i40-zero").err().unwrap_or_else(|| panic!("imported:\n{log}"))
}

fn at(e: &SpecError) -> (usize, usize) {
    let p = e.position.unwrap_or_else(|| panic!("no position: {e}"));
    (p.line, p.column)
}

fn exact(n: u32) -> TraceEvent {
    TraceEvent::Elapsed { cycles_min: n, cycles_max: Some(n) }
}

fn range(min: u32, max: u32) -> TraceEvent {
    TraceEvent::Elapsed { cycles_min: min, cycles_max: Some(max) }
}

fn command(text: &str) -> TraceEvent {
    TraceEvent::Model(Event::Command(HostCommand::parse(text).unwrap()))
}

fn unanswered(text: &str, wait_cycles: u32) -> TraceEvent {
    TraceEvent::Unanswered { command: HostCommand::parse(text).unwrap(), wait_cycles }
}

/// The events of the steps, without what the `I10` read of [`KHZ`] adds.
fn events(steps: &[Step]) -> Vec<TraceEvent> {
    steps.iter().map(|s| s.event.clone()).filter(|e| *e != command("I10")).collect()
}

#[test]
fn the_time_between_two_counter_reads_is_an_exact_elapsed_step_and_commands_between_stay_at_the_earlier_read() {
    let t = ok("> $$$\n<\n> RHX:$0\n< 000010\n> ???\n< 001000000000\n> I40\n< 0\n> RHX:$0\n< 0008CA\n");
    assert_eq!(
        events(&t.trace.steps),
        [
            command("$$$"),
            exact(0x10),
            command("RHX:$0"),
            command("???"),
            command("I40"),
            exact(0x8CA - 0x10),
            command("RHX:$0")
        ]
    );
    // The counter's value is a note, not an expectation: the model's X:$0 is its own. That
    // the card answered at all is one: it was running.
    assert_eq!(t.trace.steps[2].expect, pmacwd_trace::Expect { tripped: Some(false), ..Default::default() });
    assert!(t.trace.steps[2].note.as_deref().unwrap().contains("000010"));
    assert_eq!(t.summary.counter_reads, 2);
}

#[test]
fn the_first_counter_read_is_kept_after_an_unbounded_elapsed_of_at_least_its_value() {
    // Before it the card ran for an unknown time since its last restart, and the counter may
    // have wrapped meanwhile: at least its value, no upper bound.
    let t = ok("> RHX:$0\n< 01A2B3\n> ???\n< 001000000000\n> RHX:$0\n< 01A2C3\n");
    assert_eq!(
        events(&t.trace.steps),
        [
            TraceEvent::Elapsed { cycles_min: 0x01A2B3, cycles_max: None },
            command("RHX:$0"),
            command("???"),
            exact(0x10),
            command("RHX:$0")
        ]
    );
}

#[test]
fn after_a_reset_in_the_log_the_next_counter_read_is_exactly_the_cycles_since_it() {
    let t = ok("> RHX:$0\n< 000100\n> $$$\n<\n> RHX:$0\n< 000020\n");
    assert_eq!(t.trace.steps[2].event, command("$$$"));
    assert_eq!(t.trace.steps[3].event, exact(0x20), "no restart: the log's own `$$$` is the reset");
    assert_eq!(t.summary.restarts, 0);
}

#[test]
fn a_counter_going_backwards_without_timestamps_is_a_restart_with_a_note_not_a_wrap() {
    // The old importer inserted 2^24 - 0xFFFFF0 + 0x10 cycles here: a wrap it could not see.
    let t = ok("> RHX:$0\n< FFFFF0\n> RHX:$0\n< 000010\n");
    assert_eq!(t.trace.steps[2].event, TraceEvent::Restart);
    assert!(t.trace.steps[2].note.as_deref().unwrap().contains("without host timestamps"), "{:?}", t.trace.steps[2]);
    assert_eq!(t.trace.steps[3].event, exact(0x10), "the cycles since the restart");
    assert_eq!(t.summary.restarts, 1);
}

#[test]
fn with_timestamps_a_counter_going_backwards_is_a_wrap_when_the_host_time_fits_it() {
    // 0xFFFFF0 to 0x10 is 32 cycles across the wrap: 32 ms at 1000 Hz.
    let log = "11:59:59.000 > I10\n11:59:59.000 < 8388607\n12:00:00.000 > RHX:$0\n< FFFFF0\n\
               12:00:00.032 > RHX:$0\n< 000010\n";
    let t = ok(log);
    assert_eq!(events(&t.trace.steps)[2..], [exact(0x20), command("RHX:$0")]);
    assert_eq!(t.summary.restarts, 0);
}

#[test]
fn with_timestamps_a_counter_that_fits_no_wrap_of_the_host_time_is_a_restart() {
    let t =
        ok(&format!("{KHZ}12:00:00 > RHX:$0\n< 00A000\n12:00:01 > RHX:$0\n< 000100\n")
            .replace("> I10", "12:00:00 > I10"));
    let e = events(&t.trace.steps);
    assert_eq!(e[2..], [TraceEvent::Restart, exact(0x100), command("RHX:$0")]);
    // And a counter that advanced less than the host time allows (it stopped: the card
    // tripped, then restarted) is a restart as well.
    let t = ok("12:00:00 > I10\n< 8388607\n12:00:00 > RHX:$0\n< 000000\n12:00:10 > RHX:$0\n< 000100\n");
    assert_eq!(events(&t.trace.steps)[2], TraceEvent::Restart);
}

#[test]
fn a_counter_advancing_faster_than_the_host_clock_allows_is_an_error_naming_the_reply_line() {
    let e = err("12:00:00 > I10\n< 8388607\n12:00:00 > RHX:$0\n< 000000\n12:00:01 > RHX:$0\n< 100000\n");
    assert_eq!(at(&e), (6, 3), "{e}");
    assert!(e.message.contains("is the servo clock right?"), "{e}");
}

#[test]
fn a_stamped_log_that_does_not_read_i10_is_timed_at_the_clock_its_x0_reads_count() {
    // Seed 37 of the independent generator: a card at 1.13 kHz whose log never reads I10
    // (config-unread) was refused, "more servo cycles than the host clock allows ... at 2250
    // Hz": the card's clock is its own, and its X:$0 reads over the host's stamps count it.
    // I40-zero's configuration runs at 2250 Hz; these reads count 1128 to 1130 cycles a second
    // (564 and 565 per half second): the median, 1128.
    let mut log = String::new();
    for i in 0..6u32 {
        let t = format!("12:00:{:02}.{:03}", i / 2, (i % 2) * 500);
        log.push_str(&format!("{t} > RHX:$0\n{t} < {:06X}\n", 0x10_0000 + i * 564 + i / 2));
    }
    let t = ok(&log);
    assert_eq!(t.card.and_then(|c| c.servo_hz), Some(1128), "{:?}", t.from_log.sources);
    assert!(t.from_log.sources.iter().any(|(f, var, ..)| *f == "servo_hz" && var.contains("X:$0")));
    // A clock within 1% of the configuration's is the configuration's: the importer allows
    // 1% either way, and the stamps' resolution makes an estimate no closer.
    let mut log = String::new();
    for i in 0..6u32 {
        let t = format!("12:00:{:02}.{:03}", i / 2, (i % 2) * 500);
        log.push_str(&format!("{t} > RHX:$0\n{t} < {:06X}\n", 0x10_0000 + i * 1130));
    }
    assert_eq!(ok(&log).card.and_then(|c| c.servo_hz), None);
    // A reset between two reads breaks the count: no pair across it is taken.
    let log = "12:00:00.000 > RHX:$0\n12:00:00.000 < 100000\n12:00:00.500 > $$$\n12:00:00.500 <\n\
               12:00:01.000 > RHX:$0\n12:00:01.000 < 000800\n";
    assert_eq!(ok(log).card.and_then(|c| c.servo_hz), None);
}

#[test]
fn a_log_whose_x0_exchanges_are_slow_is_timed_at_the_clock_every_pair_allows() {
    // Seed 39 of the independent generator: a 1.13 kHz card whose log never reads I10, each
    // exchange 5 to 6 ms long (stamps to the millisecond): no read was fast enough to count the
    // clock, and the log was refused at 2250 Hz. Each pair of reads bounds the clock both ways
    // (a read happens between its command's stamp and its reply's): 1129 cycles a second, each
    // exchange 6 ms.
    let log_at = |cycles_per_ms: f64| {
        let stamp = |ms: u32| format!("12:00:{:02}.{:03}", ms / 1000, ms % 1000);
        let mut log = String::new();
        for i in 0..6u32 {
            let (sent, back) = (i * 500, i * 500 + 6);
            let count = 0x10_0000 + (f64::from(sent + 3) * cycles_per_ms) as u32;
            log.push_str(&format!("{} > RHX:$0\n{} < {count:06X}\n", stamp(sent), stamp(back)));
        }
        log
    };
    let t = ok(&log_at(1.129));
    let hz = t.card.and_then(|c| c.servo_hz).expect("a clock taken from the reads");
    assert!((1110..=1150).contains(&hz), "{hz} Hz, {:?}", t.from_log.sources);
    // The configuration's clock within what the pairs allow: kept.
    let log = log_at(2.25);
    assert_eq!(ok(&log).card.and_then(|c| c.servo_hz), None);
}

#[test]
fn every_timestamp_form_is_read_and_its_resolution_widens_the_bounds() {
    // Whole seconds, milliseconds, microseconds, a date with a space or a `T`, brackets: one
    // second between the reads of a 1000 Hz card, widened by the stamps' resolution and ±1%.
    for (a, b, lo, hi) in [
        ("12:00:00", "12:00:01", 0, 2020),
        ("12:00:00.000", "12:00:01.000", 989, 1012),
        ("12:00:00.000000", "12:00:01.000000", 989, 1011),
        ("2026-11-23 12:00:00.000", "2026-11-23 12:00:01.000", 989, 1012),
        ("[2026-11-23T12:00:00.000]", "[2026-11-23T12:00:01.000]", 989, 1012),
        ("23:59:59.500", "00:00:00.500", 989, 1012),
    ] {
        // Read as a restart, the second value being below every count the host time allows:
        // the bounds show in the error of a counter too far ahead instead.
        let log = format!("{a} > I10\n< 8388607\n{a} > RHX:$0\n< 000000\n{b} > RHX:$0\n< 100000\n");
        let e = err(&log);
        assert!(e.message.contains(&format!("({lo} to {hi} at 1000 Hz")), "{a}: {e}");
    }
    // A date changes the day: a day and a second apart is 86,401 s (86,400 to 86,402 at a
    // resolution of 1 s), which no count of turns to 0xFFFFFF fits: a restart.
    let log = "2026-11-23 12:00:00 > I10\n< 8388607\n2026-11-23 12:00:00 > RHX:$0\n< 000000\n\
               2026-11-24 12:00:01 > RHX:$0\n< FFFFFF\n";
    let t = ok(log);
    let note = t.trace.steps.iter().find(|s| s.event == TraceEvent::Restart).and_then(|s| s.note.clone()).unwrap();
    assert!(note.contains("85536000 to 87266020 servo cycles"), "{note}");
}

#[test]
fn stamping_some_command_lines_and_not_others_is_an_error_at_the_line() {
    let e = err("12:00:00 > ???\n< 000000000000\n> ???\n< 000000000000\n");
    assert_eq!(at(&e), (3, 1), "{e}");
    assert!(e.message.contains("stamp every command line or none"), "{e}");
    let e = err("> ???\n< 000000000000\n12:00:00 > ???\n< 000000000000\n");
    assert_eq!(at(&e), (3, 1), "{e}");
    // A reply line may have a stamp or not.
    ok("12:00:00 > ???\n12:00:00 < 000000000000\n12:00:01 > ???\n< 000000000000\n");
    // Time-only and dated stamps do not mix either.
    let e = err("12:00:00 > ???\n< 000000000000\n2026-01-01 12:00:01 > ???\n< 000000000000\n");
    assert_eq!(at(&e), (3, 1), "{e}");
}

#[test]
fn a_timestamp_going_backwards_is_an_error_with_its_line_but_midnight_is_a_rollover() {
    let e = err("12:00:05 > ???\n< 000000000000\n12:00:03 > ???\n< 000000000000\n");
    assert_eq!(at(&e), (3, 1), "{e}");
    assert!(e.message.contains("goes backwards"), "{e}");
    let e = err("2026-01-02 00:00:01 > ???\n< 000000000000\n2026-01-01 23:59:59 > ???\n< 000000000000\n");
    assert_eq!(at(&e), (3, 1), "{e}");
    ok("23:59:59 > ???\n< 000000000000\n00:00:01 > ???\n< 000000000000\n");
}

#[test]
fn a_malformed_timestamp_is_an_error_at_its_column() {
    for (line, column) in [
        ("12:00 > ???", 1),
        ("12:61:00 > ???", 1),
        ("12:00:00.> ???", 10),
        ("[12:00:00 > ???", 10),
        ("12:00:00> ???", 9),
        ("2026-13-01 12:00:00 > ???", 1),
    ] {
        let e = err(&format!("{line}\n< 000000000000\n"));
        assert_eq!(at(&e), (1, column), "{line}: {e}");
        assert!(e.message.contains("expected a timestamp"), "{line}: {e}");
    }
}

#[test]
fn a_silent_card_is_placed_in_time_by_the_host_clock_alone() {
    // The card stops answering after the read at 12:00:00.000; the timed-out commands are
    // placed by host time: 0.5 s then 1 s later, at 1000 Hz ±1% and 1 ms resolution.
    let log = format!(
        "12:00:00.000 {KHZ}12:00:00.000 > RHX:$0\n< 000010\n12:00:00.500 > ???\n< (timeout)\n\
         12:00:01.500 > RHX:$0\n< (timeout)\n12:00:02.000 > ???\n< (timeout)\n"
    );
    let t = ok(&log);
    let e = events(&t.trace.steps);
    assert_eq!(
        e,
        [
            TraceEvent::Elapsed { cycles_min: 0x10, cycles_max: None },
            command("RHX:$0"),
            range(494, 507),
            unanswered("???", 0),
            range(989, 1012),
            unanswered("RHX:$0", 0),
            range(494, 507),
            unanswered("???", 0),
        ]
    );
    assert_eq!(t.summary.silent_gaps, 3);
    assert!(t.summary.timing_warning().is_none(), "host time gave timing");
    // The card answers again: the counter says how much of the time it ran; what the silent
    // gaps already gave is not given twice. 2500 cycles on in 2.5 s: no restart; exactly
    // 2500 in all, less the gaps' 1977 to 2026.
    let back = format!("{log}12:00:02.500 > RHX:$0\n< {:06X}\n", 0x10 + 2500);
    let e = events(&ok(&back).trace.steps);
    assert_eq!(e[e.len() - 2..], [range(2500 - 2026, 2500 - 1977), command("RHX:$0")]);
}

#[test]
fn unstamped_timeouts_in_a_row_share_one_unknown_wait() {
    // A wait of 0 changes no card, and two gaps of any length are one: a run of unanswered
    // reads gets one unbounded `elapsed` (the search pays for each one it is given).
    let t = ok("> RHX:$0\n< 000100\n> ???\n< (timeout)\n> ???\n< (timeout)\n> RHX:$25\n< (timeout)\n");
    let unbounded =
        t.trace.steps.iter().filter(|s| matches!(s.event, TraceEvent::Elapsed { cycles_max: None, .. })).count();
    // The first X:$0 read's own (at least its value), and the silence's.
    assert_eq!(unbounded, 2, "{:#?}", t.trace.steps);
    assert_eq!(t.summary.waits_unknown, 1);
    // An answer between starts a new run.
    let t = ok("> RHX:$0\n< 000100\n> ???\n< (timeout)\n> I8\n< 2\n> ???\n< (timeout)\n");
    assert_eq!(t.summary.waits_unknown, 2);
}

#[test]
fn a_stamped_timeout_is_an_unanswered_wait_that_the_next_gap_does_not_give_again() {
    // UM p.236: host commands are processed in the background, so the 0.3 s the host waited
    // (12:00:00.501 to 12:00:00.800, at 1000 Hz less 1%: 296 cycles) passed with no background
    // cycle, or with the card tripped. The command is placed at its own stamp (494 to 507
    // cycles after the read); the next, 0.5 s after it, from the reply's end (at least 197
    // more cycles) to the command's start less the wait (at most 508 - 296). The X:$0 read
    // after it counts on: no restart.
    let log = format!(
        "12:00:00.000 {KHZ}12:00:00.000 > RHX:$0\n< 000010\n12:00:00.500 > ???\n12:00:00.800 < (timeout)\n\
         12:00:01.000 > ???\n12:00:01.001 < 000000000000\n12:00:01.100 > RHX:$0\n< {:06X}\n",
        0x10 + 1100
    );
    let t = ok(&log);
    let e = events(&t.trace.steps);
    assert_eq!(e[2..6], [range(494, 507), unanswered("???", 296), range(197, 212), command("???")], "{e:#?}");
    assert_eq!(t.summary.waits_timed, 1);
    assert_eq!(t.summary.restarts, 0);
}

#[test]
fn a_line_of_several_commands_is_split_as_the_card_splits_it_and_its_replies_paired_in_order() {
    // dls-pmaclib sends `i6=1 i3=2 ver` as one line; only `ver` answers.
    let t =
        ok("> i6=1 i3=2 ver\n< 1.947\n> I40 ??? RHY:$25\n< 0\\r001000000000 000FFC\n> OPEN PLC 1 CLOSE I130 = 5\n<\n");
    let s = &t.trace.steps;
    assert_eq!(
        events(s),
        [
            command("I6=1"),
            command("I3=2"),
            command("ver"),
            command("I40"),
            command("???"),
            command("RHY:$25"),
            command("OPEN PLC 1"),
            command("CLOSE"),
            command("I130=5")
        ]
    );
    assert_eq!(s[0].expect.reply.as_deref(), Some("(ack)"));
    assert_eq!(s[3].expect.reply.as_deref(), Some("0"));
    assert_eq!(s[4].expect.reply.as_deref(), Some("001000000000"));
    assert_eq!(s[5].expect.reply.as_deref(), Some("000FFC"));
    assert_eq!(s[8].expect.reply.as_deref(), Some("(ack)"));
    // A timeout silences the whole line; without stamps the host waited an unknown time first
    // (issue 36: not zero).
    let t = ok("> I40 I41\n< (timeout)\n");
    let (wait, commands) = t.trace.steps.split_first().expect("steps");
    assert_eq!(wait.event, TraceEvent::Elapsed { cycles_min: 0, cycles_max: None });
    assert_eq!(commands.len(), 2);
    assert!(commands.iter().all(|s| s.expect.reply.as_deref() == Some("(silence)")));
    assert_eq!(t.summary.waits_unknown, 1);
}

#[test]
fn a_command_the_model_has_no_rule_for_is_the_card_s_own_and_counted() {
    // The grammar reads every command; the model has no rule for these answers, so a replay
    // accepts whatever a running card says (but not silence).
    let t = ok("> ver\n< 1.947\n> enable plc 1\n<\n> LIST GATHER I40\n< 0\n");
    let s = &t.trace.steps;
    assert_eq!(s[0].event, command("ver"));
    assert_eq!(s[0].expect.reply.as_deref(), Some("1.947"));
    assert_eq!(s[1].expect.reply.as_deref(), Some("(ack)"));
    assert_eq!(s[2].event, command("LIST GATHER"), "two commands, where the grammar says");
    assert_eq!(s[3].event, command("I40"));
    assert_eq!(s[3].expect.reply.as_deref(), Some("0"));
    assert_eq!((t.summary.card_own, t.summary.not_modelled), (3, 0));
    // Text the grammar cannot read that the card answered: kept without an expectation.
    let t = ok("> XYZZY\n< 7\n");
    assert!(t.trace.steps[0].expect.is_empty());
    assert_eq!(t.summary.not_modelled, 1);
}

#[test]
fn an_error_reply_to_a_command_the_model_does_not_know_is_still_expected() {
    // The model answers ERR003 to what it does not know: an error reply is comparable.
    let t = ok("> ZZZ\n< ERR003\n");
    assert_eq!(t.trace.steps[0].expect.reply.as_deref(), Some("ERR003"));
    assert_eq!(t.summary.not_modelled, 0);
}

#[test]
fn a_reply_count_that_fits_no_reading_of_the_line_is_an_error_naming_both_lines() {
    let e = err("> ???\n< 000000000000\n> I40 ???\n< 0\n");
    assert_eq!(at(&e), (4, 3), "{e}");
    assert!(e.message.contains("command line 3 holds 2 commands that answer (`I40`, `???`)"), "{e}");
    let e = err("> I40 ver\n< 0 1 2\n");
    assert!(e.message.contains("2 commands that answer (`I40`, `VER`)"), "{e}");
    let e = err("> I40 LIST PROG 1\n< 0 1 2\n");
    assert!(e.message.contains("1 not modelled that may or may not answer (`LIST PROG 1`)"), "{e}");
    // And a command the model cannot follow, on a line of several, at its own column.
    let e = err("> I40 I40=I10/2\n< 0\n");
    assert_eq!(at(&e), (1, 7), "{e}");
}

#[test]
fn the_card_s_i_variables_and_servo_clock_are_read_from_the_log_before_any_write() {
    let t = ok("> I8 I41\n< 2 0\n> I40=100\n<\n> I40\n< 100\n> I10\n< 3713707\n> $$$\n<\n> I41\n< 1\n");
    let card = t.card.unwrap();
    assert_eq!((card.i8, card.i40, card.i41, card.servo_hz), (Some(2), None, Some(0), Some(2259)));
    assert_eq!(t.from_log.sources.iter().map(|s| (s.1, s.3)).collect::<Vec<_>>(), [("I8", 2), ("I10", 8), ("I41", 2)]);
    // Nothing read: no card header.
    assert!(ok("> ???\n< 000000000000\n").card.is_none());
}

#[test]
fn an_i10_of_zero_or_an_i40_out_of_range_in_the_log_is_an_error_at_its_reply_line() {
    let e = err("> ???\n< 000000000000\n> I10\n< 0\n");
    assert_eq!(at(&e).0, 4, "{e}");
    assert!(e.message.contains("I10 reads 0"), "{e}");
    let e = err("> I40\n< 70000\n");
    assert_eq!(at(&e).0, 2, "{e}");
    assert!(e.message.contains("variables.yaml"), "{e}");
    // I10 = 1 is a period of 1/8,388,608 ms, 8.4 GHz (SRM p.43): beyond u32 and far outside
    // the servo clocks of scheduling.yaml, whose derived hardware delay would be billions of
    // cycles. Refused at its line, not imported for replay to refuse later.
    let e = err("> I10\n< 1\n");
    assert_eq!(at(&e).0, 2, "{e}");
    assert!(e.message.contains("I10 reads 1") && e.message.contains("servo_clock_hz_range"), "{e}");
}

#[test]
fn a_log_without_two_counter_reads_imports_with_a_timing_warning() {
    for log in ["> ???\n< 000000000000\n", "> RHX:$0\n< 000010\n"] {
        let w = ok(log).summary.timing_warning().expect("a warning");
        assert!(w.contains("no timing can be derived"), "{w}");
    }
    assert!(ok("> RHX:$0\n< 000010\n> RHX:$0\n< 000020\n").summary.timing_warning().is_none());
}

#[test]
fn a_gap_longer_than_one_counter_turn_is_split_into_steps_whose_bounds_add_up() {
    // 33,554 s at 1000 Hz with the counter 16 cycles on: two turns (2 x 2^24 cycles) and 16,
    // the only count of turns the host time allows within ±1%; one step holds at most one turn.
    let log = "2026-01-01 00:00:00 > I10\n< 8388607\n2026-01-01 00:00:00 > RHX:$0\n< 000000\n\
               2026-01-01 09:19:14 > RHX:$0\n< 000010\n";
    let e = events(&ok(log).trace.steps);
    let gap: Vec<(u32, u32)> = e[2..e.len() - 1]
        .iter()
        .map(|e| match e {
            TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } => (*cycles_min, *max),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(gap, [(1 << 24, 1 << 24), (1 << 24, 1 << 24), (16, 16)]);
}

#[test]
fn a_reply_no_card_sends_is_unusable_input_not_a_verdict() {
    // Issue 29: a `???` reply of 11 or 13 hex digits, the ACK left in (raw or written out), a
    // NUL, or two replies to one command gave a verdict; each is a line a card never sent.
    for (log, column, says) in [
        ("> ???\n< 00000000000\n", 3, "12 hex digits"),
        ("> ???\n< 0000000000000\n", 3, "12 hex digits"),
        ("> ???\n< 000000000000\\x06\n", 15, "framing written out"),
        ("> ???\n< 000000000000\\r\\x06\n", 17, "framing written out"),
        ("> ???\n< 000000000000\x06\n", 15, "control byte"),
        ("> ???\n< 0000\x0000000000\n", 7, "control byte"),
        ("> ???\n< 000000000000 000000000000\n", 3, "holds 2 values"),
        ("> RHY:$25\n< 1000FFF\n", 3, "at most 6 hex digits"),
    ] {
        let e = err(log);
        assert_eq!(at(&e), (2, column), "{}: {e}", log.escape_debug());
        assert!(e.message.contains(says), "{}: {e}", log.escape_debug());
    }
    // `BOOTSTRAP PROM` is one `???` answer (SRM p.289), spaces and all.
    assert_eq!(ok("> ???\n< BOOTSTRAP PROM\n").trace.steps[0].expect.reply.as_deref(), Some("BOOTSTRAP PROM"));
}

// ---- Tolerant stamps and the field's own formats (docs/capturing.md) ----

use pmacwd_capture::import::{ImportStream, LogFormat};
use pmacwd_specs::Spec;

fn field(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../specs/captures/field").join(name)
}

/// A file of the test's own, removed when dropped.
struct Scratch(std::path::PathBuf);

impl Scratch {
    fn new(name: &str, bytes: &[u8]) -> Scratch {
        let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pmacwd-import");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        Scratch(path)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Every step of the log at `path` read as `format` (by content when `None`), with the line
/// (or packet) it comes from, and the stream for its summary.
fn stream(path: &Path, format: Option<LogFormat>) -> Result<(Vec<(usize, Step)>, ImportStream), SpecError> {
    let spec = Spec::embedded().unwrap();
    let mut s = ImportStream::open_as(&spec, path, "host-log", format)?;
    let mut steps = Vec::new();
    while let Some(step) = s.next_step()? {
        steps.push(step);
    }
    Ok((steps, s))
}

fn reply_of(steps: &[(usize, Step)], line: usize, text: &str) -> Option<String> {
    steps
        .iter()
        .find(|(l, s)| {
            *l == line
                && match &s.event {
                    TraceEvent::Unanswered { command: c, .. } => TraceEvent::Model(Event::Command(c.clone())),
                    e => e.clone(),
                } == command(text)
        })
        .unwrap_or_else(|| panic!("no `{text}` at line {line}"))
        .1
        .expect
        .reply
        .clone()
}

#[test]
fn slash_dates_and_a_tab_after_the_stamp_read_as_the_dashed_form_does() {
    let dashed = "2026-11-26 14:47:10.820 > I10\n2026-11-26 14:47:10.821 < 8388607\n\
                  2026-11-26 14:47:10.822 > RHX:$0\n2026-11-26 14:47:10.823 < 000010\n\
                  2026-11-26 14:47:11.822 > RHX:$0\n2026-11-26 14:47:11.823 < 0003F8\n";
    let slashed = dashed.replace('-', "/").replace(" > ", "\t> ").replace(" < ", "\t< ");
    assert!(slashed.contains("2026/11/26 14:47:10.820\t> I10"));
    assert_eq!(ok(&slashed).trace.steps, ok(dashed).trace.steps);
    // The two forms are one form for the rule "one form throughout": both are dated.
    let mixed = "2026-11-26 14:47:10.820 > I10\n2026/11/26 14:47:10.821 < 8388607\n";
    assert_eq!(ok(mixed).trace.steps.len(), 1);
    // A slash date with a dash in it is neither.
    let e = err("2026/11-26 14:47:10.820 > I10\n< 1\n");
    assert_eq!(at(&e), (1, 1));
    assert!(e.message.contains("`YYYY/MM/DD HH:MM:SS(.fff)`"), "{e}");
}

#[test]
fn the_epics_asyn_trace_of_the_field_imports_every_exchange_with_the_driver_s_command_and_the_card_s_answer() {
    let path = field("epics-asyn-trace.txt");
    let (steps, s) = stream(&path, None).unwrap();
    assert_eq!(s.format, LogFormat::Asyn);
    let sum = s.summary().unwrap();
    // 16,981 commands: the two `&1A Q71=Q81` answered ERR003 keep both their commands (the
    // error falls on the Q-variable assignment, the card's own; it fell on `&1A` before).
    assert_eq!((sum.exchanges, sum.commands, sum.unseen), (1314, 16981, 0));
    assert!(sum.stamped);
    // The trace's I10 (3713707) sets the servo clock: 2259 Hz.
    assert_eq!(s.servo_hz, 2259);
    // Line 111: the 18-command poll, whose `write 88` and `read 85` data lines asyn cut at 80
    // bytes: the command is the driver's `command:` line, the answer its `response:` line
    // (raw, with its CRs), so all 18 commands get their value, `i224` the last.
    let line = 241;
    assert_eq!(reply_of(&steps, line, "???").as_deref(), Some("001000000000"));
    assert_eq!(reply_of(&steps, line, "i224").as_deref(), Some("$0"));
    assert_eq!(steps.iter().filter(|(l, _)| *l == line).count(), 18);
    // Line 7107: `M4034` answered late (after a READREADY); the driver's `response:` line on
    // 7122 is empty, the card's bytes say `0`.
    assert_eq!(reply_of(&steps, 7122, "M4034").as_deref(), Some("0"));
    // Line 10043: `M4034` after the trip at 14:48:49: nothing came (`pmacFlush failed`,
    // `pmacReadReady failed`): silence.
    assert_eq!(reply_of(&steps, 10051, "M4034").as_deref(), Some("(silence)"));
    // An error keeps its number: `cpu` is ERR003 on this card.
    assert_eq!(reply_of(&steps, 30, "cpu").as_deref(), Some("ERR003"));
    // What is not an exchange is counted, not dropped silently.
    let passed = s.passed_over().join("\n");
    assert!(passed.contains("330 lines of other output"), "{passed}");
    assert!(
        passed.contains("6 empty command lines (the driver's connection checks: 4 answered, 2 silent)"),
        "{passed}"
    );
}

/// A few exchanges of the asyn trace, as the driver writes them.
const ASYN: &str = "2026/11/26 14:47:10.820 pmacMessageBroker::lowLevelWriteRead: command: I68
2026/11/26 14:47:10.820 127.0.0.1:45459 write 8
@\\xb3\\x00\\x00\\x00\\x00\\x00\\x00
2026/11/26 14:47:10.820 127.0.0.1:45459 read 1
\\x18
2026/11/26 14:47:10.820 127.0.0.1:45459 write 12
@\\xbf\\x00\\x00\\x00\\x00\\x00\\x04I68\\n
2026/11/26 14:47:10.820 127.0.0.1:45459 read 4
15\\r\\x06
2026/11/26 14:47:10.820 pmacMessageBroker::lowLevelWriteRead: response: 15
";

#[test]
fn an_asyn_trace_whose_request_carries_another_command_or_whose_data_is_not_escaped_is_refused_at_its_line() {
    let good = Scratch::new("good.txt", ASYN.as_bytes());
    let (steps, _) = stream(&good.0, None).unwrap();
    assert_eq!(steps.len(), 1);
    assert_eq!(steps[0].1.expect.reply.as_deref(), Some("15"));
    // The GETRESPONSE on line 7 carries `I69`, the `command:` line says `I68`.
    let other = Scratch::new("other.txt", ASYN.replace("04I68", "04I69").as_bytes());
    let e = stream(&other.0, None).err().unwrap();
    assert_eq!(at(&e), (7, 1));
    assert!(e.message.contains("carries `I69`, not the command `I68` of line 1"), "{e}");
    // The ASCII form (asynSetTraceIOMask 1) writes raw bytes: refused with what to do.
    let ascii = Scratch::new("ascii.txt", ASYN.replace("\\x18", "\x18").as_bytes());
    let e = stream(&ascii.0, None).err().unwrap();
    assert_eq!(at(&e), (5, 1));
    assert!(e.message.contains("asynSetTraceIOMask(port, 0, 2)"), "{e}");
    // A command without its response at the end of the trace.
    let cut = Scratch::new("cut.txt", ASYN.lines().take(9).collect::<Vec<_>>().join("\n").as_bytes());
    let e = stream(&cut.0, None).err().unwrap();
    assert_eq!(at(&e), (1, 72));
    assert!(e.message.contains("no `response:` line"), "{e}");
}

#[test]
fn a_log_read_in_the_wrong_format_says_which_format_it_looks_like() {
    // Read as a host log, the first line's stamp is one (a slash date), then no `>` follows.
    let e = stream(&field("epics-asyn-trace.txt"), Some(LogFormat::HostLog)).err().unwrap();
    assert_eq!(at(&e), (1, 25));
    assert!(e.message.ends_with("this looks like an EPICS asyn trace: use --log-format asyn"), "{e}");
    let e = stream(&field("emulator-session.pcap"), Some(LogFormat::Asyn)).err().unwrap();
    assert!(e.message.contains("this looks like a packet capture (pcap or pcapng): use --log-format pcap"), "{e}");
    let host = Scratch::new("host.log", b"> I10\n< 8388607\n");
    let e = stream(&host.0, Some(LogFormat::Pcap)).err().unwrap();
    assert!(e.message.contains("this looks like a host log: use --log-format host-log"), "{e}");
}

#[test]
fn a_tcpdump_capture_of_an_emulator_session_imports_each_getresponse_with_the_answer_on_its_stream() {
    let path = field("emulator-session.pcap");
    let (steps, s) = stream(&path, None).unwrap();
    assert_eq!(s.format, LogFormat::Pcap);
    let sum = s.summary().unwrap();
    assert_eq!((sum.exchanges, sum.commands, sum.counter_reads, sum.restarts), (60, 193, 23, 1));
    assert!(sum.silent_gaps > 0 && sum.stamped);
    // Packet numbers stand where a log's lines do: the first GETRESPONSE (`I8`) is packet 8,
    // after the handshake and the FLUSH with its CTRL-X.
    assert_eq!(steps[0].0, 8);
    assert_eq!(steps[0].1.expect.reply.as_deref(), Some("2"));
    assert_eq!(reply_of(&steps, steps[6].0, "cpu").as_deref(), Some("DSP56303"));
    let passed = s.passed_over().join("\n");
    assert!(passed.contains("60 FLUSH requests that are not commands"), "{passed}");
}

/// The pcap sample's packets rewritten as pcapng (section header, one interface, enhanced
/// packet blocks with microsecond stamps), as Wireshark and dumpcap write them.
fn as_pcapng(pcap: &[u8]) -> Vec<u8> {
    let le32 = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    assert_eq!(le32(pcap, 0), 0xA1B2_C3D4, "a little-endian microsecond pcap");
    let block = |kind: u32, body: &[u8]| -> Vec<u8> {
        let mut body = body.to_vec();
        while body.len() % 4 != 0 {
            body.push(0);
        }
        let len = (12 + body.len()) as u32;
        let mut b = Vec::new();
        b.extend_from_slice(&kind.to_le_bytes());
        b.extend_from_slice(&len.to_le_bytes());
        b.extend_from_slice(&body);
        b.extend_from_slice(&len.to_le_bytes());
        b
    };
    let mut out = Vec::new();
    let mut shb = Vec::new();
    shb.extend_from_slice(&0x1A2B_3C4Du32.to_le_bytes());
    shb.extend_from_slice(&1u16.to_le_bytes());
    shb.extend_from_slice(&0u16.to_le_bytes());
    shb.extend_from_slice(&u64::MAX.to_le_bytes());
    out.extend(block(0x0A0D_0D0A, &shb));
    let mut idb = Vec::new();
    idb.extend_from_slice(&(le32(pcap, 20) as u16).to_le_bytes());
    idb.extend_from_slice(&0u16.to_le_bytes());
    idb.extend_from_slice(&le32(pcap, 16).to_le_bytes());
    out.extend(block(1, &idb));
    let mut at = 24;
    while at < pcap.len() {
        let (sec, usec, caplen, origlen) =
            (le32(pcap, at), le32(pcap, at + 4), le32(pcap, at + 8), le32(pcap, at + 12));
        let ticks = u64::from(sec) * 1_000_000 + u64::from(usec);
        let mut epb = Vec::new();
        epb.extend_from_slice(&0u32.to_le_bytes());
        epb.extend_from_slice(&((ticks >> 32) as u32).to_le_bytes());
        epb.extend_from_slice(&(ticks as u32).to_le_bytes());
        epb.extend_from_slice(&caplen.to_le_bytes());
        epb.extend_from_slice(&origlen.to_le_bytes());
        epb.extend_from_slice(&pcap[at + 16..at + 16 + caplen as usize]);
        out.extend(block(6, &epb));
        at += 16 + caplen as usize;
    }
    out
}

#[test]
fn the_same_capture_as_pcapng_imports_to_the_same_steps() {
    let pcap = std::fs::read(field("emulator-session.pcap")).unwrap();
    let ng = Scratch::new("session.pcapng", &as_pcapng(&pcap));
    let (from_ng, s) = stream(&ng.0, None).unwrap();
    assert_eq!(s.format, LogFormat::Pcap);
    let (from_pcap, _) = stream(&field("emulator-session.pcap"), None).unwrap();
    assert_eq!(from_ng, from_pcap);
}

#[test]
fn a_capture_cut_short_or_missing_a_segment_is_refused_at_its_packet() {
    let pcap = std::fs::read(field("emulator-session.pcap")).unwrap();
    // Cut in the middle of a packet's record.
    let cut = Scratch::new("cut.pcap", &pcap[..pcap.len() - 10]);
    let e = stream(&cut.0, None).err().unwrap();
    assert!(e.message.contains("the capture ends in the middle of this packet"), "{e}");
    // Packet 8 (the first GETRESPONSE) left out: the stream to the card misses its bytes.
    let le32 = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize;
    let mut at = 24;
    for _ in 1..8 {
        at += 16 + le32(&pcap, at + 8);
    }
    let end = at + 16 + le32(&pcap, at + 8);
    let mut dropped = pcap[..at].to_vec();
    dropped.extend_from_slice(&pcap[end..]);
    let gap = Scratch::new("gap.pcap", &dropped);
    let e = stream(&gap.0, None).err().unwrap();
    assert!(e.message.contains("bytes of the TCP stream from port"), "{e}");
    assert!(e.message.contains("(the capture dropped packets)"), "{e}");
}

#[test]
fn an_asyn_trace_without_stamps_or_with_a_prompt_run_into_a_line_is_read_all_the_same() {
    // asynSetTraceInfoMask without the time: the lines start with the port or the driver.
    let bare: String =
        ASYN.lines().map(|l| l.strip_prefix("2026/11/26 14:47:10.820 ").unwrap_or(l)).collect::<Vec<_>>().join("\n");
    let bare = Scratch::new("bare.txt", format!("epics> {bare}\n").as_bytes());
    let (steps, s) = stream(&bare.0, None).unwrap();
    assert_eq!(steps.len(), 1);
    assert_eq!(steps[0].1.expect.reply.as_deref(), Some("15"));
    assert!(!s.summary().unwrap().stamped);
    assert!(
        s.passed_over().join("\n").contains("1 driver lines with other output run into them"),
        "{:?}",
        s.passed_over()
    );
}

/// The index of the first step that is `ev`.
fn position(steps: &[Step], ev: &TraceEvent) -> usize {
    steps.iter().position(|s| s.event == *ev).unwrap_or_else(|| panic!("no {ev:?} in {steps:#?}"))
}

#[test]
fn an_answer_after_a_silence_follows_a_restart_when_no_counter_read_comes_after_it() {
    // UM p.215: a tripped card does not communicate until it is reset, so an answer after a
    // silence comes after an unseen INIT/ (issue 36: the restart was placed at the next X:$0
    // read, after the answer, or nowhere).
    let log = format!(
        "{KHZ}12:00:00.000 > RHX:$0\n< 000100\n12:00:01.000 > ???\n12:00:02.000 < (timeout)\n\
         12:00:03.000 > ???\n12:00:03.001 < 000000000000\n"
    )
    .replace("> I10", "12:00:00.000 > I10");
    let t = ok(&log);
    let s = &t.trace.steps;
    // With no read after it the reset is only possible: a starved card answers again once its
    // background runs (UM p.236).
    let restart = position(s, &TraceEvent::RestartPossible);
    let answered = s.iter().rposition(|s| s.expect.reply.as_deref() == Some("000000000000")).expect("the answer");
    assert!(restart < answered, "{s:#?}");
    assert!(s[restart + 1..answered].iter().all(|s| matches!(s.event, TraceEvent::Elapsed { cycles_min: 0, .. })));
    assert!(s[restart].note.as_deref().unwrap().contains("UM p.215"));
    assert!(s[restart].note.as_deref().unwrap().contains("UM p.236"));
    assert!(s.iter().all(|s| s.event != TraceEvent::Restart));
    assert_eq!(t.summary.restarts, 1);
    // Without stamps the time between the reset and the answer is unknown.
    let t = ok("> RHX:$0\n< 000100\n> ???\n< (timeout)\n> ???\n< 000000000000\n");
    let s = &t.trace.steps;
    let restart = position(s, &TraceEvent::RestartPossible);
    assert_eq!(s[restart + 1].event, TraceEvent::Elapsed { cycles_min: 0, cycles_max: None });
    assert_eq!(s[restart + 2].expect.reply.as_deref(), Some("000000000000"));
}

#[test]
fn an_answer_after_a_silence_is_held_until_the_next_counter_read_says_whether_the_card_restarted() {
    let head = "12:00:00.000 > I10\n< 8388607\n12:00:00.000 > RHX:$0\n< 000100\n12:00:01.000 > ???\n\
                12:00:02.000 < (timeout)\n12:00:03.000 > ???\n12:00:03.001 < 000000000000\n12:00:04.000 > RHX:$0\n";
    // The count went back: the restart comes before the answer, once, and the read's gap is at
    // most its count.
    let t = ok(&format!("{head}< 000800\n"));
    let s = &t.trace.steps;
    let restart = position(s, &TraceEvent::Restart);
    let answered = s.iter().position(|s| s.expect.reply.as_deref() == Some("000000000000")).expect("the answer");
    assert!(restart < answered, "{s:#?}");
    assert_eq!(s.iter().filter(|s| s.event == TraceEvent::Restart).count(), 1);
    assert_eq!(t.summary.restarts, 1);
    let read_gap = &s[answered + 1];
    assert_eq!(read_gap.event, range(0, 0x800), "{s:#?}");
    // The count went on from the last read (4,000 cycles at 1 kHz): no restart fits, the
    // answer stays where it was (and no correct card explains it).
    let t = ok(&format!("{head}< 0010A0\n"));
    assert!(t.trace.steps.iter().all(|s| s.event != TraceEvent::Restart), "{:#?}", t.trace.steps);
    assert_eq!(t.summary.restarts, 0);
}

#[test]
fn the_steps_held_after_an_answer_that_follows_a_silence_are_bounded() {
    // No X:$0 read ever comes: past HELD_STEPS_MAX held steps the restart is written and the
    // rest streams (memory bounded on any log); nothing is lost.
    let n = pmacwd_capture::import::HELD_STEPS_MAX + 100;
    let mut log = String::from("> RHX:$0\n< 000100\n> ???\n< (timeout)\n");
    for _ in 0..n {
        log.push_str("> ???\n< 000000000000\n");
    }
    let t = ok(&log);
    assert_eq!(t.summary.restarts, 1);
    let s = &t.trace.steps;
    let restart = position(s, &TraceEvent::RestartPossible);
    let answers = s.iter().filter(|s| s.expect.reply.as_deref() == Some("000000000000")).count();
    assert_eq!(answers, n);
    assert!(
        s[..restart].iter().all(|s| s.expect.reply.as_deref() != Some("000000000000")),
        "the restart is before every answer"
    );
}

#[test]
fn a_command_the_grammar_stops_at_a_cr_or_a_non_breaking_space_reads_back_as_one_unreadable_step() {
    // Found by the fuzz target host_log: in `I40 ?\r? RHY:$50` the grammar stops at the CR, and
    // the step kept `? RHY:$50` with the CR trimmed off, which reads back as two commands, so
    // `pmacwd replay` refused the trace `pmacwd import` had written (exit 2).
    for (log, kept) in [
        ("> I40 ?\r? RHY:$50\n< 0\\R0010000000 1.947\n", "\r? RHY:$50"),
        ("> I40 \u{a0}? X\n< 0 ERR003\n", "\u{a0}? X"),
    ] {
        let trace = ok(log).trace;
        let last = trace.steps.last().unwrap();
        assert_eq!(last.event, TraceEvent::Model(Event::Command(HostCommand::Unrecognized(kept.into()))), "{log:?}");
        assert_eq!(HostCommand::parse(kept).unwrap(), HostCommand::Unrecognized(kept.into()));
        let lines = pmacwd_trace::jsonl::to_jsonl(&trace);
        let back = pmacwd_trace::jsonl::read_all(Path::new("s.jsonl"), lines.as_bytes())
            .unwrap_or_else(|e| panic!("{e}\n{lines}"));
        assert_eq!(format!("{trace:?}"), format!("{back:?}"));
        let yaml = pmacwd_trace::to_yaml(&trace);
        let again = pmacwd_trace::parse_yaml(Path::new("s.yaml"), &yaml).unwrap_or_else(|e| panic!("{e}\n{yaml}"));
        assert_eq!(format!("{trace:?}"), format!("{:?}", again.trace));
    }
}

/// Issues 29/36: the EPICS `pmac` driver sends `&1e` before each C.S. move
/// (`pmacHardwareTurbo::getCSEnableCommand`, "to make sure axes are enabled"). It was refused
/// (exit 2: "the model has no single command for it"); it is the vocabulary's `&1E` now
/// (MODEL: each killed motor of the C.S. closes its loop, docs/grammar.md), in a host log and
/// in an asyn trace alike, and the trace written from it reads back.
#[test]
fn the_epics_driver_s_cs_enable_imports_as_its_own_step_from_a_host_log_and_an_asyn_trace() {
    let t = ok("> $$$\n<\n> &1e\n<\n> &2E #1J/\n<\n> ???\n< 000000000000\n");
    let steps = events(&t.trace.steps);
    assert_eq!(steps[1..4], [command("&1E"), command("&2E"), command("#1J/")], "{steps:?}");
    assert_eq!(command("&1E").to_string(), command("&1e").to_string());
    // The trace as `pmacwd import` writes it (YAML and JSON Lines) reads back with the step.
    let yaml = pmacwd_trace::to_yaml(&t.trace);
    assert!(yaml.contains("&1E"), "{yaml}");
    let back = pmacwd_trace::parse_yaml(Path::new("s.yaml"), &yaml).unwrap_or_else(|e| panic!("{e}\n{yaml}"));
    assert_eq!(back.trace.steps.len(), t.trace.steps.len());
    let jsonl = pmacwd_trace::jsonl::to_jsonl(&t.trace);
    let back = pmacwd_trace::jsonl::read_all(Path::new("s.jsonl"), jsonl.as_bytes()).unwrap();
    assert!(back.steps.iter().any(|s| s.event == command("&1E")), "{jsonl}");
    // The driver's asyn trace of the same command: `command: &1e`, the GETRESPONSE carrying
    // it, the card's bare ACK, an empty `response:`.
    let enable = ASYN
        .replace("command: I68", "command: &1e")
        .replace("04I68", "04&1e")
        .replace("read 4\n15\\r\\x06", "read 1\n\\x06")
        .replace("response: 15", "response: ");
    let trace = Scratch::new("enable.txt", enable.as_bytes());
    let (steps, s) = stream(&trace.0, None).unwrap_or_else(|e| panic!("{e}\n{enable}"));
    assert_eq!(s.format, LogFormat::Asyn);
    assert_eq!(steps.len(), 1, "{steps:?}");
    // The step is placed at the `response:` line, as every asyn exchange is.
    assert_eq!((steps[0].0, &steps[0].1.event), (10, &command("&1E")));
}

/// A short correct log of the driver's C.S. move replays as explained: after a reset every
/// motor is killed (MODEL, Ixx80 = 0), `&1E` closes the loops of &1's motors (the host-log
/// configuration's eight), so `B` and `R` start the program and `#1K` is refused with ERR001
/// while it runs (UM p.319). Without the `&1E`, R starts nothing (UM p.319: a program starts
/// from closed loops), K is taken, and ERR001 is no correct card's answer.
#[test]
fn a_short_log_of_the_driver_s_enable_then_a_program_run_replays_as_explained() {
    use pmacwd_capture::explain::report::{explain, to_text};
    let replay = |name: &str, text: &str| {
        let scratch = Scratch::new(name, text.as_bytes());
        explain(&Spec::embedded().unwrap(), &scratch.0, None).unwrap_or_else(|e| panic!("{e}\n{text}"))
    };
    let log = "> $$$\n<\n> RHX:$0\n< 000010\n> &1e\n<\n> &1B10R\n<\n> #1K\n< ERR001\n> ???\n< 000000000000\n\
               > RHX:$0\n< 000020\n";
    let r = replay("enable.log", log);
    assert!(r.explained(), "{}", to_text(&r));
    let r = replay("no-enable.log", &log.replace("> &1e\n<\n", ""));
    assert!(!r.explained(), "{}", to_text(&r));
}

/// Issue 29: the EPICS `pmac` driver sends `&1A Q71=Q81` to stop a C.S. axis; the card that
/// answered it ERR003 (the trace of `../shared/reference/captures`, line 9,632) refused one of
/// the two, and the log cannot say which. The importer gave the error to `&1A`, which the model
/// acknowledges, so every reading found the log impossible there. The error now falls on the
/// card's own command among those it may answer (a Q-variable assignment: no rule of the
/// model), the commands before it acknowledged, those after it never run; with none of the
/// card's own, the first as before.
#[test]
fn an_error_that_may_answer_several_commands_falls_on_the_card_s_own_command_among_them() {
    let t = ok("> $$$\n<\n> &1A Q71=Q81\n< ERR003\n> #1J/ M140=1 ???\n< ERR003\n> #1J/ #2J/\n< ERR003\n");
    let got: Vec<(String, Option<String>)> =
        t.trace.steps.iter().skip(1).map(|s| (s.event.to_string(), s.expect.reply.clone())).collect();
    let want: Vec<(String, Option<String>)> =
        [("&1A", "(ack)"), ("&1Q71=Q81", "ERR003"), ("#1J/", "(ack)"), ("M140=1", "ERR003"), ("#1J/", "ERR003")]
            .iter()
            .map(|(c, r)| (format!("host sends `{c}`"), Some(r.to_string())))
            .collect();
    assert_eq!(got, want);
}

#[test]
fn the_card_s_running_checksum_is_kept_as_its_own_value_and_reads_back_in_both_forms() {
    // Issue 36: `RHX:$1080`'s value was only a note; replay needs it for the freeze of UM p.217.
    // It is kept as `running_checksum`, never as a `reply` (which would be compared with the
    // model's token); X:$1090 and CHECKSUM stay notes (no rule of the manual reads a log's).
    let t = ok("> $$$\n<\n> RHX:$1080 CHECKSUM RHX:$1090\n< 3a7f21 00C0FFEE 001234\n> RHX:$1080\n< 7\n");
    let kept: Vec<(Option<u32>, Option<&str>)> =
        t.trace.steps.iter().map(|s| (s.expect.running_checksum, s.expect.reply.as_deref())).collect();
    assert_eq!(kept[1..], [(Some(0x3A7F21), None), (None, None), (None, None), (Some(7), None)], "{kept:?}");
    assert!(t.trace.steps[1..].iter().all(|s| s.expect.tripped == Some(false)));
    let jsonl = pmacwd_trace::jsonl::to_jsonl(&t.trace);
    assert!(jsonl.contains(r#""running_checksum":3833633"#), "{jsonl}");
    let back = pmacwd_trace::jsonl::read_all(Path::new("s.jsonl"), jsonl.as_bytes()).unwrap();
    assert_eq!(back.steps, t.trace.steps);
    let yaml = pmacwd_trace::to_yaml(&t.trace);
    let again = pmacwd_trace::parse_yaml(Path::new("s.yaml"), &yaml).unwrap_or_else(|e| panic!("{e}\n{yaml}"));
    assert_eq!(again.trace.steps, t.trace.steps);
    // A reply that is no 24-bit hex word is refused at its line (SRM p.295), as for every
    // register; an error reply stays what it was (compared: the model answers the read).
    for bad in ["1000000", "+10", "3A7F2G"] {
        let e = err(&format!("> ???\n< 000000000000\n> RHX:$1080\n< {bad}\n"));
        assert_eq!(at(&e), (4, 3), "{e}");
        assert!(e.message.contains("24-bit word"), "{e}");
    }
    let t = ok("> RHX:$1080\n< ERR003\n");
    assert_eq!(t.trace.steps[0].expect.reply.as_deref(), Some("ERR003"));
    assert_eq!(t.trace.steps[0].expect.running_checksum, None);
}
