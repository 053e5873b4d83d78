/*
 * The Promela twin of the checker's `timing` configuration (specs/check.yaml) under the
 * default profile `um-215`, written from docs/model.md and model/src/controller.rs and
 * checker.rs for issue 32: the same reachable state set as `pmacwd check --configuration
 * timing --profile um-215` (57,536 states), so that SPIN's search and stateright's do equal
 * work. model/spin/run.sh compiles and runs it; model/tests/spin_twin.rs holds its count to
 * the checker's.
 *
 * One process, one loop: every environment event of WatchdogModel::actions is one d_step
 * whose first statement is its guard, so each event is one transition from the loop head back
 * to it, and the states pan stores are exactly the valuations of the variables below at the
 * loop head (no intermediate states).
 *
 * The configuration: servo_hz 2250, I8 = 1, I40 = 3 (saved), I41 = 0, hardware delay 2
 * cycles, one servo cycle at a time, X:$0 masked to 0 bits, cycle_units 4, one unit per motor,
 * four loads, supplies 5000 and 4500 mV, commands ??? and I40=1, resets INIT/ and power, no
 * checksum faults, passes of one background cycle, bit 22 clearable.
 *
 * What the checker's state holds that does not vary at `timing`, and is left out here: the
 * eight motors and their coordinate systems' programs (no motion command, no encoder or
 * amplifier-fault input: every motor stays killed as at power-up, and a trip's kill leaves it
 * so), I8 and I41 (no command writes them), the other I-variables (none written), bootstrap,
 * the DPRAM and flash error bits (no reset injects them), the buffers and data gathering (no
 * command opens them), the checksum engine's contents, references, error and position (no
 * fault: each pass of one cycle matches and the engine moves to the other area, position back
 * at 0), X:$0 (masked to 0 bits) and the monitors' violation bits (every property holds, so
 * they stay 0). Each of these is constant in every reachable state of the checker, so leaving
 * it out maps the checker's states one to one onto these.
 */

#define CYCLE_UNITS   4   /* cpu.cycle_units */
#define SERVO_UNITS   1   /* cpu.servo_units_per_motor */
#define I8            1
#define I40_SAVED     3
#define DELAY         2   /* hardware_delay_cycles */

/* The load: which of check.yaml's four. */
#define L_MOTORS(l) ((l) == 3 -> 5 : 1)
#define L_PLC0(l)   ((l) == 1 -> 6 : ((l) == 2 -> 8 : 0))
#define L_BG(l)     3

#define NONE    0
#define UNDERV  1   /* TripCause::Undervoltage */
#define STROBE  2   /* TripCause::StrobeTimeout */
#define BY_INIT  1  /* ResetKind::Init */
#define BY_POWER 2  /* ResetKind::Power */

byte trip = NONE;
bool supply_low = false;
short counter = I40_SAVED;      /* Y:$25 */
short counter_min = I40_SAVED;  /* X:$25 */
byte cycles_since_strobe = 0;
byte rti_phase = 0;
byte rti_remaining = 0;
byte background_credit = 0;
byte load = 0;
byte i40 = I40_SAVED;
bool rti_reentry = false;       /* X bit 22 */
bool rti_warning = false;       /* X bit 9 */
bool servo_error = false;       /* X bit 20 */
bool area_user = false;         /* the checksum engine's area: firmware (0) or user program */
bool led_red = false;
bool fefco_on = false;
bool relay_tripped = false;
bool forced_off = false;
byte ghost_since_background = 0;
short ghost_last_reload = I40_SAVED;
byte ghost_recovered_by = NONE;

/* Scratch of one transition, kept out of the state vector (`hidden`). */
hidden byte spare = 0;
hidden byte work = 0;
hidden byte strobe = 0;
hidden byte was_tripped = 0;

/* UM p.215: latched reset state, red LED, FEFCO/ on, relay changed over, ICs held in reset. */
inline trip_now(cause) {
    trip = cause;
    led_red = true; fefco_on = true; relay_tripped = true; forced_off = true;
    ghost_recovered_by = NONE
}

/* Controller::restart with the saved I-variables (INIT/, power). */
inline restart() {
    trip = NONE;
    i40 = I40_SAVED;
    counter = I40_SAVED;
    counter_min = counter;
    cycles_since_strobe = 0; rti_phase = 0; rti_remaining = 0; background_credit = 0;
    rti_reentry = false; rti_warning = false; servo_error = false;
    area_user = false;
    led_red = false; fefco_on = false; relay_tripped = false; forced_off = false;
    ghost_since_background = 0; ghost_last_reload = counter
}

inline reset(kind) {
    was_tripped = (trip != NONE);
    if
    :: kind == BY_POWER -> supply_low = false   /* MODEL: power comes back at a good supply */
    :: else -> skip
    fi;
    restart();
    if
    :: supply_low -> trip_now(UNDERV)
    :: else -> if :: was_tripped -> ghost_recovered_by = kind :: else -> skip fi
    fi
}

/* Some of the `always` state properties (properties.rs), checked in every state as the checker
 * checks its conjunction: X:$25 <= Y:$25 <= the last reload (SRM p.57); a tripped card's
 * outputs (UM p.215); a low supply means tripped (UM p.215); a background starved for longer
 * than the reload plus the hardware delay means tripped (UM p.215). The checker checks 92
 * properties and the transition monitors besides: the twin's search does less per state, so
 * the ratio it gives is, if anything, in SPIN's favour. */
#define SAFE (counter_min <= counter && counter <= ghost_last_reload \
    && (trip == NONE || (led_red && fefco_on && relay_tripped && forced_off)) \
    && (!supply_low || trip != NONE) \
    && (trip != NONE || ghost_since_background <= ghost_last_reload + DELAY))

active proctype card() {
    do
    /* One servo cycle (Controller::servo_cycle, um-215: at_zero, servo_interrupt, level). A
     * tripped card's servo interrupt does nothing (UM p.215), but the event is offered. */
    :: d_step {
        true;
        if
        :: trip == NONE ->
            if :: ghost_since_background < 255 -> ghost_since_background++ :: else -> skip fi;
            /* SRM p.289 bit 20: the servo routines need more than the cycle. */
            servo_error = (L_MOTORS(load) * SERVO_UNITS > CYCLE_UNITS);
            spare = (servo_error -> 0 : CYCLE_UNITS - L_MOTORS(load) * SERVO_UNITS);
            /* UM p.215: decrement while above zero; the strobe toggles while it does. */
            if
            :: counter > 0 -> counter--; strobe = true
            :: else -> strobe = false
            fi;
            /* SRM p.57: X:$25 the lowest value since reset. */
            if :: counter < counter_min -> counter_min = counter :: else -> skip fi;
            /* UM p.236: the RTI every I8+1 servo cycles. */
            if
            :: rti_phase >= I8 ->
                rti_phase = 0;
                if
                :: rti_remaining > 0 -> rti_reentry = true; rti_warning = true   /* SRM p.289, p.290 */
                :: else -> rti_warning = false; rti_remaining = L_PLC0(load)
                fi
            :: else -> rti_phase++
            fi;
            work = (spare < rti_remaining -> spare : rti_remaining);
            rti_remaining = rti_remaining - work;
            spare = spare - work;
            background_credit = (background_credit + spare < L_BG(load) -> background_credit + spare : L_BG(load));
            if
            :: strobe -> cycles_since_strobe = 0
            :: else ->
                cycles_since_strobe++;
                if :: cycles_since_strobe > DELAY -> trip_now(STROBE) :: else -> skip fi   /* UM p.215 */
            fi
        :: else -> skip
        fi;
        assert(SAFE)
    }
    /* The end of a background cycle (UM p.215: the counter reloaded to I40; UM p.217: the
     * checksum engine's step, a pass of one cycle that matches). */
    :: d_step {
        trip == NONE && background_credit >= L_BG(load);
        background_credit = 0;
        counter = i40;
        if :: counter < counter_min -> counter_min = counter :: else -> skip fi;
        ghost_since_background = 0;
        ghost_last_reload = counter;
        area_user = !area_user;
        assert(SAFE)
    }
    /* A change of load, to each of the other three. */
    :: d_step { trip == NONE && load != 0; load = 0; assert(SAFE) }
    :: d_step { trip == NONE && load != 1; load = 1; assert(SAFE) }
    :: d_step { trip == NONE && load != 2; load = 2; assert(SAFE) }
    :: d_step { trip == NONE && load != 3; load = 3; assert(SAFE) }
    /* SRM p.289: bit 22 cleared by hand. */
    :: d_step { trip == NONE && rti_reentry; rti_reentry = false; assert(SAFE) }
    /* ???: a reply, no change (a tripped card is silent). */
    :: d_step { true; assert(SAFE) }
    /* I40=1 (SRM p.57: I41 = 0 locks nothing); a tripped card takes no write. */
    :: d_step { true; if :: trip == NONE -> i40 = 1 :: else -> skip fi; assert(SAFE) }
    /* Supply readings, each offered when it changes whether the supply is low (UM p.215). */
    :: d_step { supply_low; supply_low = false; assert(SAFE) }
    :: d_step { !supply_low; supply_low = true; if :: trip == NONE -> trip_now(UNDERV) :: else -> skip fi; assert(SAFE) }
    /* INIT/ and power (UM p.215). */
    :: d_step { true; reset(BY_INIT); assert(SAFE) }
    :: d_step { true; reset(BY_POWER); assert(SAFE) }
    od
}
