//! k prediction (seed 003 §4.2): the k a frame needs, from a depth-complexity histogram, a memory
//! budget and a robustness ratio.
//!
//! The budget bounds k first: k_b is the largest k whose frame fits in `--budget-mb`, by the
//! method's own memory formula (its descriptor's `k_memory`, [`frame_bytes`]: x·k bytes per pixel
//! plus its fixed part for the slot arrays and the MDT cascades; Σ min(f(p), k) pooled slots for
//! `kplus-sbuffer`). Then k is
//! the smallest k ≤ k_b whose captured fragments Σ min(f(p), k) reach the fraction R of all
//! fragments Σ f(p). When even k_b falls short of R, k = k_b and the predicted robustness says by
//! how much. Methods that store every fragment (`kb-ab-*`, `kb-sbuffer`, `kb-ll`) have no k in
//! their memory: only R picks their k, and their pools answer to the budget themselves.
//!
//! The histogram's last bin holds every pixel of 1023 or more fragments; they count as 1023, so
//! for such scenes the prediction is an estimate (the achieved robustness, measured on the frame,
//! is not).

use super::{
    max_k, sample_frame_bytes_besides_storage, sample_storage, sbuffer::scan_levels, SLOT_BYTES,
};
use crate::error::{Error, Result};
use crate::frame::RenderOptions;
use crate::methods::kbuffer::KBufferOptions;
use crate::methods::MethodId;

/// `--robustness` when `--k auto` is given alone (the paper's figures use 95%).
pub const DEFAULT_ROBUSTNESS: f64 = 0.95;

/// The k chosen for a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KChoice {
    /// The k chosen.
    pub k: u32,
    /// The largest k the budget holds (the method's limit without a budget).
    pub k_budget: u32,
    /// Σ min(f, k) / Σ f over the histogram (1 for a frame without fragments).
    pub predicted_robustness: f64,
}

/// Fragments Σ min(f, k) a histogram (bin f = pixels with f fragments) keeps at k.
pub fn captured(histogram: &[u64], k: u32) -> u64 {
    histogram
        .iter()
        .enumerate()
        .map(|(f, &pixels)| (f as u64).min(k as u64) * pixels)
        .sum()
}

/// The bytes `id` allocates at `k` for a frame whose depth complexity is `histogram` (`None`:
/// every pixel as deep as k), by its descriptor's formula (`Descriptor::k_memory`), or `None` for
/// methods without one.
pub fn frame_bytes(
    id: MethodId,
    k: u32,
    histogram: Option<&[u64]>,
    options: &RenderOptions,
) -> Option<u64> {
    let bytes = id.descriptor().k_memory?;
    Some(bytes(id, k, histogram, options))
}

/// What a k-buffer frame of `id` allocates besides its fragment storage, and its storage pixels
/// (per sample with `--msaa` where the method keeps its storage per sample).
fn fixed_part(id: MethodId, options: &RenderOptions) -> (u64, u64) {
    let px = options.pixels();
    let samples = sample_storage(id, options.build.msaa);
    let tail = options.frame.family::<KBufferOptions>().tail.kept();
    let fixed = sample_frame_bytes_besides_storage(px, samples, tail);
    (fixed, px * samples as u64)
}

/// k slots of `slot_bytes` per storage pixel, besides the fixed part (slot arrays, cascades).
pub(crate) fn k_slots(id: MethodId, k: u32, options: &RenderOptions, slot_bytes: u64) -> u64 {
    let (fixed, pixels) = fixed_part(id, options);
    fixed + slot_bytes * k as u64 * pixels
}

/// [`k_slots`] of [`SLOT_BYTES`]: the slot k-buffers' formula.
pub(crate) fn slot_array(id: MethodId, k: u32, _: Option<&[u64]>, o: &RenderOptions) -> u64 {
    k_slots(id, k, o, SLOT_BYTES)
}

/// min(f, k) slots a pixel from a prefix sum over the regions (`kplus-sbuffer`; with `--msaa`
/// a region per sample pixel, each as deep as its pixel at most).
pub(crate) fn pooled_regions(
    id: MethodId,
    k: u32,
    histogram: Option<&[u64]>,
    options: &RenderOptions,
) -> u64 {
    let (fixed, regions) = fixed_part(id, options);
    let samples = regions / options.pixels().max(1);
    let slots = match histogram {
        Some(h) => captured(h, k) * samples,
        None => k as u64 * regions,
    };
    fixed + 4 * regions + 4 * scan_levels(regions).1 + SLOT_BYTES * slots
}

/// A method that stores every fragment: k is not in its memory, only its fixed part (its pool
/// answers to the budget itself).
pub(crate) fn every_fragment(id: MethodId, _: u32, _: Option<&[u64]>, o: &RenderOptions) -> u64 {
    fixed_part(id, o).0
}

/// Chooses k for `id` from `histogram` (see the module docs); without a histogram (a first
/// frame), `first_guess` bounded by the budget with every pixel as deep as k. An error when the
/// method has no k or the budget cannot hold k = 1.
pub fn choose_k(
    id: MethodId,
    histogram: Option<&[u64]>,
    robustness: f64,
    first_guess: u32,
    options: &RenderOptions,
) -> Result<KChoice> {
    if frame_bytes(id, 1, histogram, options).is_none() {
        return Err(Error::input(format!(
            "--k auto applies to the k-buffer methods, not {id}"
        )));
    }
    let bytes = |k: u32| frame_bytes(id, k, histogram, options).expect("checked above");
    let k_budget = budget_bound(max_k(id), bytes, options.budget_bytes()).ok_or_else(|| {
        Error::input(format!(
            "{id}: --budget-mb {} cannot hold even k = 1 at {}x{} ({:.2} MiB needed)",
            options.frame.budget_mb.unwrap_or(0.0),
            options.frame.width,
            options.frame.height,
            bytes(1) as f64 / 1048576.0
        ))
    })?;
    Ok(match histogram {
        Some(h) => select(h, robustness, k_budget),
        None => KChoice {
            k: first_guess.clamp(1, k_budget),
            k_budget,
            predicted_robustness: f64::NAN,
        },
    })
}

/// The largest k in 1..=max_k with bytes(k) ≤ budget (bytes grows with k), `None` when k = 1
/// does not fit.
pub fn budget_bound(max_k: u32, bytes: impl Fn(u32) -> u64, budget: Option<u64>) -> Option<u32> {
    let Some(budget) = budget else {
        return Some(max_k);
    };
    if bytes(1) > budget {
        return None;
    }
    let (mut fits, mut too_big) = (1u32, max_k + 1);
    while too_big - fits > 1 {
        let mid = fits + (too_big - fits) / 2;
        if bytes(mid) <= budget {
            fits = mid;
        } else {
            too_big = mid;
        }
    }
    Some(fits)
}

/// The smallest k ≤ k_budget capturing the fraction `robustness` of the histogram's fragments,
/// else k_budget.
pub fn select(histogram: &[u64], robustness: f64, k_budget: u32) -> KChoice {
    let total = captured(histogram, u32::MAX);
    if total == 0 {
        return KChoice {
            k: 1,
            k_budget,
            predicted_robustness: 1.0,
        };
    }
    // deeper[j]: pixels with more than j fragments; captured(k) = Σ_{j<k} deeper[j].
    let mut deeper = vec![0u64; histogram.len()];
    let mut above = 0;
    for j in (0..histogram.len()).rev() {
        deeper[j] = above;
        above += histogram[j];
    }
    let mut kept = 0u64;
    let mut k = 0u32;
    while k < k_budget {
        kept += deeper.get(k as usize).copied().unwrap_or(0);
        k += 1;
        if kept as f64 / total as f64 >= robustness {
            break;
        }
    }
    KChoice {
        k,
        k_budget,
        predicted_robustness: kept as f64 / total as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameOptions;
    use proptest::prelude::*;

    fn options(size: u32, budget_mb: Option<f64>) -> RenderOptions {
        RenderOptions {
            frame: FrameOptions {
                width: size,
                height: size,
                budget_mb,
                ..Default::default()
            },
            ..Default::default()
        }
    }

    /// The paper's worked case: a budget of x·k + y bytes per pixel bounds k at
    /// (budget/pixels − y)/x.
    #[test]
    fn the_budget_bounds_k_by_the_methods_formula() {
        let opts = options(256, Some(16.0));
        let px = 65536u64;
        let h = [0, 0, 0, 0, 0, 0, 0, 0, px];
        let c = choose_k(MethodId::KplusHeap, Some(&h), 1.0, 16, &opts).unwrap();
        let fixed = 16 * px + 116 + 40;
        assert_eq!(c.k_budget as u64, (16 * 1048576 - fixed) / (16 * px));
        assert_eq!(c.k, 8);
        assert_eq!(c.predicted_robustness, 1.0);
        // kplus-sbuffer pays only for Σ min(f, k): half the pixels empty, twice the k.
        let h = [px / 2, 0, 0, 0, px / 2];
        let c = choose_k(MethodId::KplusSbuffer, Some(&h), 0.75, 16, &opts).unwrap();
        assert_eq!(c.k, 3);
        assert_eq!(c.predicted_robustness, 0.75);
        assert_eq!(c.k_budget, max_k(MethodId::KplusSbuffer));
    }

    #[test]
    fn impossible_budgets_and_methods_without_k_are_errors() {
        let opts = options(256, Some(0.5));
        let e = choose_k(MethodId::KplusArray, None, 0.9, 16, &opts).unwrap_err();
        assert!(e.to_string().contains("cannot hold even k = 1"), "{e}");
        let e = choose_k(MethodId::F2b, None, 0.9, 16, &options(8, None)).unwrap_err();
        assert!(e.to_string().contains("k-buffer methods"), "{e}");
    }

    /// The unified buffer's ends: a tiny R keeps the nearest surface (k = 1), R = 1 the whole
    /// A-buffer (k = the deepest pixel).
    #[test]
    fn robustness_spans_the_nearest_surface_to_the_a_buffer() {
        let h = [5, 3, 0, 7, 0, 2];
        assert_eq!(select(&h, 1e-9, 1024).k, 1);
        assert_eq!(select(&h, 1.0, 1024).k, 5);
        assert_eq!(select(&[9], 0.9, 1024).k, 1);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        /// On random histograms, budgets and ratios: k fits the budget, reaches R when the budget
        /// allows (and no smaller k does), else takes the whole budget; the prediction is the
        /// histogram's captured fraction at k.
        #[test]
        fn selection_is_minimal_within_the_budget(
            bins in proptest::collection::vec(0u64..2000, 1..80),
            robustness in 0.01f64..=1.0,
            budget_kib in 1u64..4096,
            kplus_sbuffer in any::<bool>(),
        ) {
            let id = if kplus_sbuffer { MethodId::KplusSbuffer } else { MethodId::KplusHeap };
            let opts = options(64, Some(budget_kib as f64 / 1024.0));
            let budget = opts.budget_bytes().unwrap();
            let Ok(c) = choose_k(id, Some(&bins), robustness, 16, &opts) else {
                prop_assert!(frame_bytes(id, 1, Some(&bins), &opts).unwrap() > budget);
                return Ok(());
            };
            let bytes = |k| frame_bytes(id, k, Some(&bins), &opts).unwrap();
            prop_assert!(c.k >= 1 && c.k <= c.k_budget && c.k_budget <= max_k(id));
            prop_assert!(bytes(c.k) <= budget);
            prop_assert!(c.k_budget == max_k(id) || bytes(c.k_budget + 1) > budget);
            let total = captured(&bins, u32::MAX);
            let fraction = |k| if total == 0 { 1.0 } else { captured(&bins, k) as f64 / total as f64 };
            prop_assert_eq!(c.predicted_robustness, fraction(c.k));
            if c.predicted_robustness >= robustness {
                prop_assert!(c.k == 1 || fraction(c.k - 1) < robustness);
            } else {
                prop_assert_eq!(c.k, c.k_budget);
            }
        }
    }
}
