#define_import_path strata::steps

// A shader invocation's budget of loop steps where a loop's length depends on the data (a
// pixel's fragments, a tile's list): docs/watchdog.md, bound B1. A GPU has no limit of its own,
// so one deep pixel could keep its invocation — and the dispatch, and the frame — running past
// a display watchdog; 65535 steps stay within about 20 ms even when each step is a dependent
// load. Lavapipe ends every loop of an invocation after 65535 iterations in all, silently
// (ARCHITECTURE, "Lavapipe ends loops"); these steps are among those, so on lavapipe its own
// limit comes first and nothing changes. A loop takes a step before each iteration and ends
// when it is refused; whoever runs the loops reports the pass cut short (`steps_spent`), and the
// frame is refused with the reason instead of composited from a partial pass.
#ifdef STEP_LIMIT
const STEP_LIMIT: u32 = #{STEP_LIMIT}u;
#else
const STEP_LIMIT: u32 = 65535u;
#endif

var<private> steps_taken: u32 = 0u;

// One more iteration of a data-bounded loop; false once the invocation has taken STEP_LIMIT
// (later loops then end at once). The count stops at STEP_LIMIT + 1: it never wraps.
fn step() -> bool {
    if steps_taken > STEP_LIMIT {
        return false;
    }
    steps_taken += 1u;
    return steps_taken <= STEP_LIMIT;
}

// Whether some loop of this invocation was refused a step.
fn steps_spent() -> bool {
    return steps_taken > STEP_LIMIT;
}
