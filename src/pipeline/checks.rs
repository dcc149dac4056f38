//! Checks on a set of logs used together: one rig (constants within 1 %),
//! and no test counted twice.

use crate::identify::LogFit;
use crate::ingest::RigMeta;
use std::path::{Path, PathBuf};

/// Relative difference of a rig constant (M1, M2, K1, K2, d) above which
/// two logs count as different rigs.
pub const RIG_TOLERANCE: f64 = 0.01;

/// Refuses logs whose rig constants (M1, M2, K1, K2, d) differ by more
/// than 1 % from the first log's, unless `allow` (then `None`): one error
/// naming both logs and every differing constant.
pub fn refuse_mixed_rigs(rigs: &[(PathBuf, RigMeta)], allow: bool) -> crate::Result<()> {
    if allow {
        return Ok(());
    }
    let Some((p0, r0)) = rigs.first() else {
        return Ok(());
    };
    for (p, r) in &rigs[1..] {
        let diffs: Vec<String> = [
            ("M1", "kg", r0.m1_kg, r.m1_kg),
            ("M2", "kg", r0.m2_kg, r.m2_kg),
            ("K1", "N/m", r0.k1_n_per_m, r.k1_n_per_m),
            ("K2", "N/m", r0.k2_n_per_m, r.k2_n_per_m),
            ("d", "N s/m", r0.d_n_s_per_m, r.d_n_s_per_m),
        ]
        .iter()
        .filter(|(_, _, a, b)| (a - b).abs() > RIG_TOLERANCE * a.abs().max(b.abs()))
        .map(|(name, unit, a, b)| {
            format!(
                "{name} = {b} {unit} against {a} {unit} ({:+.1} %)",
                100.0 * (b / a - 1.0)
            )
        })
        .collect();
        if !diffs.is_empty() {
            return Err(crate::Error::Input {
                path: p.clone(),
                msg: format!(
                    "rig constants differ from {} by more than 1 %: {}; logs of different rigs are refused (give --allow-mixed-rigs to use them together)",
                    p0.display(),
                    diffs.join(", ")
                ),
            });
        }
    }
    Ok(())
}

/// What identifies one test for finding it given twice: the file, its rig
/// record and what was measured in it.
pub struct TestId<'a> {
    /// The log as given.
    pub path: &'a Path,
    /// Its rig record.
    pub rig: &'a RigMeta,
    /// Measured normal force (N).
    pub normal_force_n: f64,
    /// Measured drive amplitude (m).
    pub drive_amplitude_m: f64,
    /// Measured drive frequency (Hz).
    pub drive_frequency_hz: f64,
}

/// Finds the same test given twice: the same file (after resolving the
/// path), or the same test in another format (the same rig record, with a
/// `recorded_at`, and the same measured normal force, drive amplitude and
/// frequency within 2 %, 1 % and 0.5 %). Returns which entries to keep (the
/// first of each test) and a warning per duplicate; two logs with the same
/// record whose data differ are kept, with a warning.
pub fn find_duplicates(ids: &[TestId<'_>]) -> (Vec<bool>, Vec<crate::warning::Warning>) {
    let mut keep = vec![true; ids.len()];
    let mut warnings = Vec::new();
    let canon: Vec<Option<PathBuf>> = ids
        .iter()
        .map(|t| std::fs::canonicalize(t.path).ok())
        .collect();
    let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * a.abs().max(b.abs());
    for j in 0..ids.len() {
        for i in 0..j {
            if !keep[i] {
                continue;
            }
            let (a, b) = (&ids[i], &ids[j]);
            if canon[i].is_some() && canon[i] == canon[j] {
                keep[j] = false;
                warnings.push(crate::warning::Warning::DuplicateFile {
                    log: b.path.to_path_buf(),
                });
                break;
            }
            if a.rig.recorded_at.is_some() && a.rig.to_map() == b.rig.to_map() {
                if close(a.normal_force_n, b.normal_force_n, 0.02)
                    && close(a.drive_amplitude_m, b.drive_amplitude_m, 0.01)
                    && close(a.drive_frequency_hz, b.drive_frequency_hz, 0.005)
                {
                    keep[j] = false;
                    warnings.push(crate::warning::Warning::DuplicateTest {
                        log: b.path.to_path_buf(),
                        of: a.path.to_path_buf(),
                        recorded_at: a.rig.recorded_at.clone(),
                    });
                    break;
                }
                warnings.push(crate::warning::Warning::SameRecord {
                    first: a.path.to_path_buf(),
                    second: b.path.to_path_buf(),
                    normal_force_n: (a.normal_force_n, b.normal_force_n),
                    drive_amplitude_m: (a.drive_amplitude_m, b.drive_amplitude_m),
                });
            }
        }
    }
    (keep, warnings)
}

/// Keeps one of each test given twice (same rig, normal force and drive;
/// see [`find_duplicates`]) among fitted logs (`good`) and their rig
/// records (`rigs`, in the same order): the names set aside and the
/// warnings saying so. Shared by the `batch` job and a plan's batch.
pub fn drop_duplicates(
    good: &mut Vec<(PathBuf, LogFit)>,
    rigs: &mut Vec<(PathBuf, RigMeta)>,
) -> (Vec<String>, Vec<crate::warning::Warning>) {
    let (keep, dup_warnings) = {
        let ids: Vec<TestId<'_>> = good
            .iter()
            .zip(rigs.iter())
            .map(|((p, f), (_, rig))| TestId {
                path: p,
                rig,
                normal_force_n: f.normal_force_n,
                drive_amplitude_m: f.drive.amplitude_m,
                drive_frequency_hz: f.drive.frequency_hz,
            })
            .collect();
        find_duplicates(&ids)
    };
    let duplicates: Vec<String> = good
        .iter()
        .zip(&keep)
        .filter(|(_, k)| !**k)
        .map(|((p, _), _)| p.display().to_string())
        .collect();
    let mut k = keep.iter();
    good.retain(|_| *k.next().unwrap_or(&true));
    let mut k = keep.iter();
    rigs.retain(|_| *k.next().unwrap_or(&true));
    (duplicates, dup_warnings)
}

/// Reads logs in parallel (results in the order given) and checks that
/// each is a characteristic test, before any fitting: the first log that
/// cannot be read (a log too long to fit is refused before it is
/// decoded), or that records another test (a sweep), is the error. Their
/// channels as recorded are dropped: the fit reads the common grid only.
pub fn read_characteristic_logs(paths: &[PathBuf]) -> crate::Result<Vec<crate::ingest::Run>> {
    use rayon::prelude::*;
    let opts = crate::ingest::IngestOptions {
        max_samples: Some(crate::limits::MAX_FIT_SAMPLES),
        ..Default::default()
    };
    let runs: Vec<crate::Result<crate::ingest::Run>> = paths
        .par_iter()
        // `ingest::read` guards its decoders against panics itself.
        .map(|p| {
            let mut run = crate::ingest::read(p, &opts)?;
            run.channels = Vec::new();
            Ok(run)
        })
        .collect();
    let mut out = Vec::with_capacity(runs.len());
    for (p, r) in paths.iter().zip(runs) {
        let run = r?;
        if run.rig.test != crate::ingest::TestKind::Characteristic {
            return Err(crate::Error::Input {
                path: p.clone(),
                msg: format!(
                    "is a {} log: a batch compares characteristic logs only (one per normal-force setting)",
                    run.rig.test.as_str()
                ),
            });
        }
        out.push(run);
    }
    Ok(out)
}

/// Checks the logs as [`read_characteristic_logs`] does, then fits them
/// (in parallel, results in the order given). Where the logs' planned
/// memory ([`crate::limits::planned_fit_bytes`], counted before any is
/// decoded) fits `opts.memory_bytes` together, they are read once, checked
/// and fitted; otherwise they are checked in rounds that fit it, each log
/// let go once checked, then read again and fitted in rounds
/// ([`crate::identify::fit_logs`]): a batch of long logs is never held at
/// once.
pub fn fit_characteristic_logs(
    paths: &[PathBuf],
    opts: &crate::identify::IdentifyOptions,
    tick: &(dyn Fn() + Sync),
) -> crate::Result<Vec<crate::Result<(RigMeta, crate::identify::LogFit)>>> {
    let budget = opts.memory_bytes;
    let planned = crate::identify::planned_fit_memory(paths, budget);
    let rounds = crate::limits::rounds(&planned, budget);
    if rounds.len() <= 1 {
        let runs = read_characteristic_logs(paths)?;
        let refs: Vec<&crate::ingest::Run> = runs.iter().collect();
        let fits = crate::identify::fit_runs(&refs, opts, tick);
        return Ok(runs
            .iter()
            .zip(fits)
            .map(|(run, f)| f.map(|f| (run.rig.clone(), f)))
            .collect());
    }
    for round in rounds {
        read_characteristic_logs(&paths[round])?;
    }
    Ok(crate::identify::fit_logs(paths, opts, tick))
}
