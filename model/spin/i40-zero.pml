/*
 * The Promela twin of the checker's `i40-zero` configuration (specs/check.yaml) under the
 * default profile `um-215`, written from docs/model.md and model/src/controller.rs and
 * checker.rs for issue 32: the same reachable state set as `pmacwd check --configuration
 * i40-zero --profile um-215` (3,578 states). model/spin/run.sh compiles and runs it;
 * model/tests/spin_twin.rs holds its count to the checker's.
 *
 * As in timing.pml, every event is one d_step from the loop head back to it. Time advances as
 * the checker's leaps do (checker.rs, `advance_to_change`): servo cycle after servo cycle, each
 * simulated whole, up to the first cycle whose signature (the trip, the counter's sign, whether
 * a background cycle could complete, the status words) differs from the start's, or to the
 * cycle just before it; a leap of no cycle leaves the state as it was.
 *
 * The configuration: servo_hz 2250, I8 = 2, I40 = 0 (reset value 4096 under um-215, SRM p.57 /
 * UM p.215), I41 = 0, hardware delay derived: 2250 / (2 x 25 Hz) = 45 cycles (UM p.215), 8
 * motors at one unit each of a 100-unit cycle, two loads (PLC 0 of 30 and of 276 units, a
 * background cycle of 250), supplies 5000 and 4600 mV, commands ??? and $$$*** (UM p.243: the
 * factory defaults, which are this configuration's saved I8, I40 and I41), resets INIT/ and
 * power, no checksum faults, firmware passes of 2 background cycles and user-program passes
 * of 1, bit 22 not clearable.
 *
 * Left out, each constant in every reachable state of the checker (see timing.pml): the
 * motors and programs, I8, I40, I41, the other I-variables, bootstrap, the DPRAM and flash
 * bits, buffers and gathering, the checksum contents, references and error, X:$0, the
 * violation bits; and servo_error, which 8 motors of one unit in a cycle of 100 never set.
 */

#define CYCLE_UNITS  100
#define SERVO_UNITS  8      /* 8 motors x servo_units_per_motor 1 */
#define I8           2
#define RESET_VALUE  4096   /* I40 = 0 under um-215 (UM p.215, p.237) */
#define DELAY        45
#define BG_UNITS     250
#define L_PLC0(l)    ((l) == 0 -> 30 : 276)
#define FW_PASS      2
#define USER_PASS    1

#define NONE    0
#define UNDERV  1
#define STROBE  2
#define BY_INIT  1
#define BY_POWER 2

byte trip = NONE;
bool supply_low = false;
short counter = RESET_VALUE;
short counter_min = RESET_VALUE;
byte cycles_since_strobe = 0;
byte rti_phase = 0;
short rti_remaining = 0;
short background_credit = 0;
byte load = 0;
bool rti_reentry = false;
bool rti_warning = false;
bool area_user = false;
byte position = 0;
bool led_red = false;
bool fefco_on = false;
bool relay_tripped = false;
bool forced_off = false;
short ghost_since_background = 0;
short ghost_last_reload = RESET_VALUE;
byte ghost_recovered_by = NONE;

/* Scratch of one transition, kept out of the state vector. */
hidden short spare = 0;
hidden short work = 0;
hidden byte strobe = 0;
hidden byte was_tripped = 0;
hidden byte start_sig = 0;
hidden byte changed = 0;
/* The cycle's starting point, for the leap that stops just before the change. */
hidden byte b_trip; hidden byte b_supply_low; hidden short b_counter; hidden short b_counter_min;
hidden byte b_css; hidden byte b_rti_phase; hidden short b_rti_remaining; hidden short b_credit;
hidden byte b_reentry; hidden byte b_warning; hidden byte b_area_user; hidden byte b_position;
hidden byte b_outputs; hidden short b_since_bg; hidden short b_last_reload; hidden byte b_recovered;

/* checker.rs `signature`: the trip, counter > 0, counter >= 0, whether a background cycle
 * could complete, and the status words' driven bits (22, 9, and 12: the firmware checksum's
 * pass, SRM p.289; 20 never set here). */
#define SIG ((trip) | (counter > 0) << 2 | (counter >= 0) << 3 \
    | (trip == NONE && background_credit >= BG_UNITS) << 4 \
    | rti_reentry << 5 | rti_warning << 6 | area_user << 7)

inline trip_now(cause) {
    trip = cause;
    led_red = true; fefco_on = true; relay_tripped = true; forced_off = true;
    ghost_recovered_by = NONE
}

inline restart() {
    trip = NONE;
    counter = RESET_VALUE;
    counter_min = counter;
    cycles_since_strobe = 0; rti_phase = 0; rti_remaining = 0; background_credit = 0;
    rti_reentry = false; rti_warning = false;
    area_user = false; position = 0;
    led_red = false; fefco_on = false; relay_tripped = false; forced_off = false;
    ghost_since_background = 0; ghost_last_reload = counter
}

inline reset(kind) {
    was_tripped = (trip != NONE);
    if
    :: kind == BY_POWER -> supply_low = false
    :: else -> skip
    fi;
    restart();
    if
    :: supply_low -> trip_now(UNDERV)
    :: else -> if :: was_tripped -> ghost_recovered_by = kind :: else -> skip fi
    fi
}

/* Controller::servo_cycle on a running card (um-215: at_zero, servo_interrupt, level). */
inline servo_cycle() {
    if :: ghost_since_background < 32767 -> ghost_since_background++ :: else -> skip fi;
    spare = CYCLE_UNITS - SERVO_UNITS;
    if
    :: counter > 0 -> counter--; strobe = 1
    :: else -> strobe = 0
    fi;
    if :: counter < counter_min -> counter_min = counter :: else -> skip fi;
    if
    :: rti_phase >= I8 ->
        rti_phase = 0;
        if
        :: rti_remaining > 0 -> rti_reentry = true; rti_warning = true
        :: else -> rti_warning = false; rti_remaining = L_PLC0(load)
        fi
    :: else -> rti_phase++
    fi;
    work = (spare < rti_remaining -> spare : rti_remaining);
    rti_remaining = rti_remaining - work;
    spare = spare - work;
    background_credit = (background_credit + spare < BG_UNITS -> background_credit + spare : BG_UNITS);
    if
    :: strobe -> cycles_since_strobe = 0
    :: else ->
        cycles_since_strobe++;
        if :: cycles_since_strobe > DELAY -> trip_now(STROBE) :: else -> skip fi
    fi
}

inline save() {
    b_trip = trip; b_supply_low = supply_low; b_counter = counter; b_counter_min = counter_min;
    b_css = cycles_since_strobe; b_rti_phase = rti_phase; b_rti_remaining = rti_remaining;
    b_credit = background_credit; b_reentry = rti_reentry; b_warning = rti_warning;
    b_area_user = area_user; b_position = position; b_outputs = led_red;
    b_since_bg = ghost_since_background; b_last_reload = ghost_last_reload; b_recovered = ghost_recovered_by
}

inline restore() {
    trip = b_trip; supply_low = b_supply_low; counter = b_counter; counter_min = b_counter_min;
    cycles_since_strobe = b_css; rti_phase = b_rti_phase; rti_remaining = b_rti_remaining;
    background_credit = b_credit; rti_reentry = b_reentry; rti_warning = b_warning;
    area_user = b_area_user; position = b_position;
    led_red = b_outputs; fefco_on = b_outputs; relay_tripped = b_outputs; forced_off = b_outputs;
    ghost_since_background = b_since_bg; ghost_last_reload = b_last_reload; ghost_recovered_by = b_recovered
}

/* A leap: servo cycles up to the first whose signature differs; with just_before, the state
 * one cycle before it. */
inline leap(just_before) {
    start_sig = SIG;
    changed = 0;
    do
    :: changed -> break
    :: else ->
        save();
        servo_cycle();
        if
        :: SIG != start_sig ->
            changed = 1;
            if :: just_before -> restore() :: else -> skip fi
        :: else -> skip
        fi
    od
}

#define SAFE (counter_min <= counter && counter <= ghost_last_reload \
    && (trip == NONE || (led_red && fefco_on && relay_tripped && forced_off)) \
    && (!supply_low || trip != NONE) \
    && (trip != NONE || ghost_since_background <= ghost_last_reload + DELAY))

active proctype card() {
    do
    :: d_step { trip == NONE; leap(0); assert(SAFE) }
    :: d_step { trip == NONE; leap(1); assert(SAFE) }
    /* A tripped card's servo interrupt does nothing (UM p.215); the event is offered. */
    :: d_step { trip != NONE; assert(SAFE) }
    /* The end of a background cycle: the counter reloaded (UM p.215), the checksum engine's
     * step (UM p.217): a firmware pass of 2 cycles, a user-program pass of 1, each matching. */
    :: d_step {
        trip == NONE && background_credit >= BG_UNITS;
        background_credit = 0;
        counter = RESET_VALUE;
        if :: counter < counter_min -> counter_min = counter :: else -> skip fi;
        ghost_since_background = 0;
        ghost_last_reload = counter;
        position++;
        if
        :: (!area_user && position >= FW_PASS) || (area_user && position >= USER_PASS) ->
            position = 0; area_user = !area_user
        :: else -> skip
        fi;
        assert(SAFE)
    }
    :: d_step { trip == NONE && load != 0; load = 0; assert(SAFE) }
    :: d_step { trip == NONE && load != 1; load = 1; assert(SAFE) }
    /* ???: a reply, no change. */
    :: d_step { true; assert(SAFE) }
    /* $$$*** (UM p.243): a reset to the factory defaults, which are the saved values here; a
     * command, so a tripped card ignores it, and not a reset of the supply check. */
    :: d_step { true; if :: trip == NONE -> restart() :: else -> skip fi; assert(SAFE) }
    :: d_step { supply_low; supply_low = false; assert(SAFE) }
    :: d_step { !supply_low; supply_low = true; if :: trip == NONE -> trip_now(UNDERV) :: else -> skip fi; assert(SAFE) }
    :: d_step { true; reset(BY_INIT); assert(SAFE) }
    :: d_step { true; reset(BY_POWER); assert(SAFE) }
    od
}
