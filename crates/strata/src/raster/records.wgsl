#define_import_path strata::raster::records
#import strata::raster::items::{raster_counters, rp}
#import strata::raster::setup::{SETUP_RECORD_WORDS, SetupTriangle, record_triangle}

// The setup records the bin stage stored with SETUP_RECORDS (tiled): one per set-up fan
// triangle, read by the passes after the bin instead of transforming and clipping again.

@group(#{RASTER_GROUP}) @binding(4) var<storage, read> setup_records: array<u32>;

// Records the bin stage wrote (those past the buffer overflowed and are reported).
fn records_written() -> u32 {
    let written = raster_counters[2];
    if raster_counters[3] != 0u || written > rp.setup_capacity {
        return rp.setup_capacity;
    }
    return written;
}

// A stored triangle and its primitive.
struct Recorded {
    prim: u32,
    t: SetupTriangle,
}

fn recorded_triangle(index: u32) -> Recorded {
    var words: array<u32, SETUP_RECORD_WORDS>;
    for (var w = 0u; w < SETUP_RECORD_WORDS; w++) {
        words[w] = setup_records[index * SETUP_RECORD_WORDS + w];
    }
    return Recorded(words[0], record_triangle(words));
}
