//! The memory budget every size is checked against before anything is
//! allocated (issue 29), the thread-count clamp, and the bounded read of
//! small text inputs (plans, channel maps, sensor sets) with the checks logs
//! get. A size that fits the budget runs; one that cannot is refused up
//! front with the numbers and what to change. This module depends on no
//! other module of the crate (ingest and io both use it).

/// The memory one command may plan to hold (bytes): 2 GB. Sizes that can
/// be given or read (shard counts, curves × points, plan entries, DAQ
/// buffer lengths, log duration × rate) are checked against it before any
/// allocation.
pub const MEMORY_BUDGET_BYTES: u64 = 2_000_000_000;

/// Most worker threads: more than this many times the machine's cores only
/// adds start-up and switching cost (`RAYON_NUM_THREADS=100000` turned a
/// 0.05 s sweep into minutes).
pub const THREADS_PER_CORE: usize = 4;

/// Memory per steady state of a sweep family, all copies counted (the
/// computed row, the table row, the JSON and table being written):
/// measured 1.13 kB (1 curve × 100 000 points with `--out x.parquet
/// --json` peaked at 133 MB), rounded up.
pub const FAMILY_POINT_BYTES: u64 = 1200;

/// Most steady states (curves × points) of one sweep family or merged
/// table: what fits [`MEMORY_BUDGET_BYTES`] at [`FAMILY_POINT_BYTES`] each
/// (about 1.67 million).
pub const MAX_FAMILY_POINTS: u64 = MEMORY_BUDGET_BYTES / FAMILY_POINT_BYTES;

/// Memory the fit of one log takes per sample of its common grid (bytes,
/// all copies counted: the run, the contact signals, the equation-error
/// and output-error fits, one calibration re-fit at a time: more run at
/// once only where [`concurrent_refits`] allows). Measured on two-hour
/// 1 kHz logs (7.2 million samples; peak resident memory with one and two
/// threads): a 7-column CSV 264–267 bytes per sample, an MCAP log 264;
/// rounded up (`docs/measurements.md`, "A two-hour log fitted within the
/// budget", issue 29). Was 600 before the fit's columns were shared.
pub const FIT_BYTES_PER_SAMPLE: u64 = 275;

/// Memory a fit takes beside its per-sample part (bytes): the program,
/// thread stacks and the blocks the allocator keeps, which weigh most on
/// logs of a few hundred thousand samples. Resident memory above
/// [`FIT_BYTES_PER_SAMPLE`] per sample, one thread: 14 MB at 20 000
/// samples (bundled logs), 38 MB at 0.6 million (MCAP), 39 MB at 1 million
/// (CSV); at 7.2 million the per-sample figure holds it. Rounded up. Counted
/// where several logs share the budget ([`planned_fit_bytes`]) and beside
/// a fit's concurrent re-fits ([`concurrent_refits`]); a log alone may use
/// the whole budget ([`MAX_FIT_SAMPLES`]).
pub const FIT_FIXED_BYTES: u64 = 50_000_000;

/// Memory one calibration re-fit of a log takes beside the fit itself, per
/// sample (bytes): its characteristic (the contact signals, the
/// segmentation) and its equation-error fit. Measured with all five
/// re-fits at once against one at a time: a 1 kHz MCAP log of 1200 s
/// peaked at 1169 MB against 643 MB (110 bytes per sample and re-fit), a
/// 3000-s CSV log at 3.27 GB against 1.61 GB (138); rounded up
/// (`docs/measurements.md`, issue 29).
pub const REFIT_BYTES_PER_SAMPLE: u64 = 150;

/// How many of a log's calibration re-fits may run at once within `budget`
/// bytes: the fit itself ([`FIT_FIXED_BYTES`] plus [`FIT_BYTES_PER_SAMPLE`]
/// per sample, which counts one re-fit) and every further concurrent
/// re-fit ([`REFIT_BYTES_PER_SAMPLE`]) must fit, whatever the thread
/// count. At least one.
pub fn concurrent_refits(samples: u64, budget: u64) -> usize {
    let base = samples
        .saturating_mul(FIT_BYTES_PER_SAMPLE)
        .saturating_add(FIT_FIXED_BYTES);
    let each = samples.saturating_mul(REFIT_BYTES_PER_SAMPLE).max(1);
    let extra = budget.saturating_sub(base) / each;
    usize::try_from(extra.saturating_add(1)).unwrap_or(usize::MAX)
}

/// The memory planned for fitting a log of `samples` grid samples, as far
/// as they are known before it is decoded (`None`: unknown, the whole
/// `budget`). A log over [`MAX_FIT_SAMPLES`] is refused by its reader as
/// soon as that is known, so plans only [`REFUSAL_BYTES`].
pub fn planned_fit_bytes(samples: Option<u64>, budget: u64) -> u64 {
    match samples {
        None => budget,
        Some(n) if n > MAX_FIT_SAMPLES => REFUSAL_BYTES,
        Some(n) => n
            .saturating_mul(FIT_BYTES_PER_SAMPLE)
            .saturating_add(FIT_FIXED_BYTES),
    }
}

/// What a refused case may hold (the bound on every refusal).
pub const REFUSAL_BYTES: u64 = 500_000_000;

/// Consecutive groups of items (in order) whose planned bytes together fit
/// `budget`, to be run one group after the other, the items of a group at
/// once; an item over the budget forms a group of its own. Every item is
/// in exactly one group.
pub fn rounds(planned: &[u64], budget: u64) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    let mut sum = 0u64;
    for (i, &b) in planned.iter().enumerate() {
        if i > start && sum.saturating_add(b) > budget {
            out.push(start..i);
            start = i;
            sum = 0;
        }
        sum = sum.saturating_add(b);
    }
    if start < planned.len() {
        out.push(start..planned.len());
    }
    out
}

/// Most samples one log may have to be fitted within [`MEMORY_BUDGET_BYTES`]
/// (7.27 million: two hours and a minute at 1 kHz).
pub const MAX_FIT_SAMPLES: u64 = MEMORY_BUDGET_BYTES / FIT_BYTES_PER_SAMPLE;

/// Why a family of steady states is refused ([`check_family`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FamilyError {
    /// More steady states than [`MAX_FAMILY_POINTS`].
    #[error("{curves} curves x {points} etas = {:.3e} steady states would need {} (about {FAMILY_POINT_BYTES} bytes each), over {}: at most {MAX_FAMILY_POINTS} steady states per family; use fewer --rho-s values or --points, or run several families", *.curves as f64 * *.points as f64, human(*.curves as f64 * *.points as f64 * FAMILY_POINT_BYTES as f64), budget_text())]
    TooLarge {
        /// Curves of the family.
        curves: u64,
        /// Points (η values) per curve.
        points: u64,
    },
    /// Curve or point indices that do not fit in 32 bits.
    #[error("{curves} curves x {points} etas: indices beyond 2^32 cannot be stored")]
    IndicesTooLarge {
        /// Curves of the family.
        curves: u64,
        /// Points (η values) per curve.
        points: u64,
    },
    /// More shards than steady states.
    #[error("{shards} shards for a family of {curves} curves x {points} etas: at most one shard per steady state ({units})")]
    TooManyShards {
        /// Shards asked for.
        shards: u64,
        /// Curves of the family.
        curves: u64,
        /// Points (η values) per curve.
        points: u64,
        /// Steady states of the family (at least 1).
        units: u64,
    },
}

/// Checks a family of `curves` × `points` steady states (and `shards`
/// slices of it) against the budget: `Err` says what is too large, with
/// the numbers and what to change.
pub fn check_family(curves: u64, points: u64, shards: u64) -> Result<(), FamilyError> {
    let total = curves.checked_mul(points);
    match total {
        Some(t) if t <= MAX_FAMILY_POINTS => {}
        _ => return Err(FamilyError::TooLarge { curves, points }),
    }
    if curves > u64::from(u32::MAX) || points > u64::from(u32::MAX) {
        return Err(FamilyError::IndicesTooLarge { curves, points });
    }
    let units = total.unwrap_or(0).max(1);
    if shards > units {
        return Err(FamilyError::TooManyShards {
            shards,
            curves,
            points,
            units,
        });
    }
    Ok(())
}

/// The bytes `count` items of `item_bytes` each would take, or `None` if
/// that overflows.
pub fn bytes(count: u64, item_bytes: u64) -> Option<u64> {
    count.checked_mul(item_bytes)
}

/// Whether `count` items of `item_bytes` fit the budget.
pub fn fits(count: u64, item_bytes: u64) -> bool {
    bytes(count, item_bytes).is_some_and(|b| b <= MEMORY_BUDGET_BYTES)
}

/// Why a log of `samples` samples is not fitted (at most `max`): the
/// message after what was counted (`subject`, e.g. "12000000 data rows").
pub fn fit_refusal(subject: &str, samples: u64, max: u64) -> String {
    format!(
        "{subject}: fitting takes about {} ({FIT_BYTES_PER_SAMPLE} bytes per sample), over {}: at most {max} samples are fitted; split the log into shorter ones",
        human(samples as f64 * FIT_BYTES_PER_SAMPLE as f64),
        budget_text()
    )
}

/// A byte count as people read it (`9.0 GB`, `512 MB`).
pub fn human(bytes: f64) -> String {
    if bytes >= 1e9 {
        format!("{:.1} GB", bytes / 1e9)
    } else if bytes >= 1e6 {
        format!("{:.0} MB", bytes / 1e6)
    } else {
        format!("{:.0} kB", bytes / 1e3)
    }
}

/// The budget as messages name it.
pub fn budget_text() -> String {
    format!("the {} memory budget", human(MEMORY_BUDGET_BYTES as f64))
}

/// The most worker threads on this machine.
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (cores * THREADS_PER_CORE).max(1)
}

/// Clamps `RAYON_NUM_THREADS` to [`max_threads`] with one warning on
/// stderr (before the thread pool starts). A value that is not a number is
/// left to rayon (which ignores it).
pub fn thread_budget() {
    let Ok(v) = std::env::var("RAYON_NUM_THREADS") else {
        return;
    };
    let Ok(n) = v.trim().parse::<u64>() else {
        return;
    };
    let max = max_threads();
    if n > max as u64 {
        eprintln!(
            "warning: RAYON_NUM_THREADS={n} is more than {THREADS_PER_CORE} threads per core; using {max} threads"
        );
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(max)
            .build_global();
    }
}

/// What kind of special file this is, if it is not a regular file or a
/// directory.
pub fn special_kind(t: &std::fs::FileType) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    if t.is_fifo() {
        Some("a FIFO (named pipe)")
    } else if t.is_char_device() || t.is_block_device() {
        Some("a device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        None
    }
}

/// Why a small text input was not read.
#[derive(Debug)]
pub enum SmallReadError {
    /// The operating system's error.
    Io(std::io::Error),
    /// Refused: what is wrong (without the path).
    Refused(String),
}

/// Reads a small text input (a plan, a channel map, a sensor set) with the
/// checks logs get, before any read: a regular file (a FIFO would hang, a
/// device never end, a directory is not a file) of at most `max_bytes`
/// (refused with the numbers: no such file is that large), UTF-8. `what`
/// names it in messages.
pub fn read_small_text(
    path: &std::path::Path,
    what: &str,
    max_bytes: u64,
) -> Result<String, SmallReadError> {
    use std::io::Read;
    let refused = |m: String| SmallReadError::Refused(m);
    let m = std::fs::metadata(path).map_err(SmallReadError::Io)?;
    if m.is_dir() {
        return Err(refused(format!(
            "is a directory, not a {what}: give the file itself"
        )));
    }
    if let Some(kind) = special_kind(&m.file_type()) {
        return Err(refused(format!(
            "is {kind}, not a regular file: give the {what} file itself"
        )));
    }
    if m.len() > max_bytes {
        return Err(refused(format!(
            "is {} bytes, more than a {what} can be ({max_bytes} bytes at most): is it the right file?",
            m.len()
        )));
    }
    let file = std::fs::File::open(path).map_err(SmallReadError::Io)?;
    let mut bytes = Vec::new();
    // The file may grow after the check: read no more than the limit.
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(SmallReadError::Io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(refused(format!(
            "grew beyond {max_bytes} bytes while being read"
        )));
    }
    String::from_utf8(bytes).map_err(|_| refused(format!("is not a text {what} (not UTF-8)")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budget_arithmetic() {
        assert!(fits(1000, 8));
        assert!(!fits(u64::MAX, 2));
        assert!(!fits(1_000_000_000_000, 16));
        assert_eq!(human(9.0e9), "9.0 GB");
        assert!(max_threads() >= THREADS_PER_CORE);
        assert!(check_family(13, 141, 4).is_ok());
        let e = check_family(10_000, 100_000, 1).unwrap_err().to_string();
        assert!(
            e.contains("1.000e9 steady states") && e.contains("1200.0 GB"),
            "{e}"
        );
        assert!(check_family(1, 4_294_967_297, 1).is_err());
        assert!(check_family(u64::MAX, 2, 1).is_err());
        assert!(check_family(2, 3, 7)
            .unwrap_err()
            .to_string()
            .contains("7 shards"));
    }

    /// The calibration re-fits of a log run as many at once as fit the
    /// budget beside the fit: all five for a 20-s log, one for the
    /// longest log the fit takes, and never more memory than the budget
    /// where more than one runs.
    #[test]
    fn concurrent_refits_stay_within_the_budget() {
        let b = MEMORY_BUDGET_BYTES;
        assert!(concurrent_refits(20_000, b) >= 5);
        assert_eq!(concurrent_refits(MAX_FIT_SAMPLES, b), 1);
        assert_eq!(concurrent_refits(u64::MAX, b), 1);
        assert_eq!(concurrent_refits(0, b) as u64, b - FIT_FIXED_BYTES + 1);
        let mut last = usize::MAX;
        for n in [1_000u64, 100_000, 1_000_000, 2_000_000, 3_000_000] {
            let c = concurrent_refits(n, b);
            assert!(c <= last, "{n}: {c} > {last}");
            last = c;
            let peak = FIT_FIXED_BYTES
                + n * FIT_BYTES_PER_SAMPLE
                + (c as u64 - 1) * n * REFIT_BYTES_PER_SAMPLE;
            assert!(
                c == 1 || peak <= b,
                "{n} samples, {c} at once: {peak} bytes"
            );
        }
        // A smaller share allows fewer at once.
        assert!(concurrent_refits(1_000_000, b / 4) < concurrent_refits(1_000_000, b));
    }

    /// Rounds keep the order, cover every item once, fit the budget
    /// (but for an item over it, alone) and are as long as the budget
    /// allows.
    #[test]
    fn rounds_cover_every_item_within_the_budget() {
        assert!(rounds(&[], 10).is_empty());
        assert_eq!(rounds(&[3, 3, 3, 3], 10), vec![0..3, 3..4]);
        assert_eq!(
            rounds(&[11, 1, 1, 20, 5, 5], 10),
            vec![0..1, 1..3, 3..4, 4..6]
        );
        assert_eq!(rounds(&[u64::MAX, u64::MAX], 10), vec![0..1, 1..2]);
        assert_eq!(rounds(&[0; 5], 0), vec![0..5]);
        let planned: Vec<u64> = (0..200u64).map(|i| (i * 7919) % 13).collect();
        let r = rounds(&planned, 20);
        let mut next = 0;
        for g in &r {
            assert_eq!(g.start, next);
            next = g.end;
            let sum: u64 = planned[g.clone()].iter().sum();
            assert!(sum <= 20 || g.len() == 1, "{g:?}: {sum}");
            if g.end < planned.len() {
                assert!(sum + planned[g.end] > 20, "{g:?} could take the next");
            }
        }
        assert_eq!(next, planned.len());
        assert_eq!(planned_fit_bytes(None, 7), 7);
        assert_eq!(
            planned_fit_bytes(Some(10), 7),
            FIT_FIXED_BYTES + 10 * FIT_BYTES_PER_SAMPLE
        );
        assert_eq!(
            planned_fit_bytes(Some(MAX_FIT_SAMPLES + 1), MEMORY_BUDGET_BYTES),
            REFUSAL_BYTES
        );
    }
}
