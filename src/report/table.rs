//! Frequency-response tables (`sweep --out`, `merge`): one row per steady
//! state, written as Parquet or CSV (polars, by extension, atomically) and
//! read back for merging the partial tables of a sharded study.
//!
//! Columns: `curve`, `point` (indices in the family, for merging), `m`, `k`,
//! `damping`, `rho_s`, `rho_d`, `slope`, `v_s`, `stop_below`, `direction`,
//! `eta`, `amplitude1`, `amplitude2`, `steady`, `period_multiple`,
//! `stick_fraction`, `interrupted`, `method`, `periods`, `coexisting`,
//! `amplitude1_min`, `amplitude1_max`, `amplitude2_min`, `amplitude2_max`
//! (the range of the per-period amplitudes where no steady state was found,
//! [`crate::sim::sweep::AmplitudeRange`]; empty elsewhere). A family with a
//! direction-dependent law adds `rho_s_minus`, `rho_d_minus` (empty on
//! symmetric curves), one with a contact spring `contact_stiffness` (empty
//! for a rigid stick); a table without them reads as symmetric and rigid.
//!
//! `coexisting` is true where the family holds another branch (direction
//! `up`, `down` or `rest`) of the same model whose settled steady state at
//! the same η differs by more than 1e-6 relative
//! ([`crate::sim::sweep::distinct_states`]): two stable states coexist
//! there. It holds for the branches and the grid computed: a single
//! direction can never show it, and other states may exist unseen.
//! [`mark_coexisting`] sets it; `merge` re-marks the joined table, so
//! branches computed in different shards are compared too.
//!
//! Each table also says where it sits in its family ([`TableMeta`]): the
//! shard `K/N` it holds and the family's size (curves × η points), as
//! Parquet key-value metadata (`stickslip.shard`, `stickslip.curves`,
//! `stickslip.points`) or, in CSV, one leading comment line
//! `# stickslip sweep table: shard=K/N curves=C points=P`. `merge` uses it
//! to name missing shards, even one that held whole curves (or no rows).

use crate::error::{Error, Result};
use crate::sim::sweep::AmplitudeRange;
use polars::prelude::*;
use std::path::Path;

/// One row of a frequency-response table.
#[derive(Debug, Clone, PartialEq)]
pub struct FrcRow {
    /// Curve index in the family.
    pub curve: u32,
    /// η index on the grid.
    pub point: u32,
    /// m.
    pub m: f64,
    /// k.
    pub k: f64,
    /// D.
    pub damping: f64,
    /// ρs.
    pub rho_s: f64,
    /// ρd.
    pub rho_d: f64,
    /// D*.
    pub slope: f64,
    /// Stribeck velocity, if the law has one.
    pub v_s: Option<f64>,
    /// Interruption level factor, if set.
    pub stop_below: Option<f64>,
    /// ρs⁻ of a direction-dependent law (None: symmetric).
    pub rho_s_minus: Option<f64>,
    /// ρd⁻ of a direction-dependent law (None: symmetric).
    pub rho_d_minus: Option<f64>,
    /// κ of a contact spring (None: the rigid stick).
    pub contact_stiffness: Option<f64>,
    /// `up`, `down` or `rest`.
    pub direction: String,
    /// η.
    pub eta: f64,
    /// A1/A.
    pub amplitude1: Option<f64>,
    /// A2/A.
    pub amplitude2: Option<f64>,
    /// Periodic response found.
    pub steady: bool,
    /// n of a period-n response.
    pub period_multiple: Option<u32>,
    /// Stick fraction.
    pub stick_fraction: f64,
    /// Interrupted by the paper's rule.
    pub interrupted: bool,
    /// How the point was settled.
    pub method: String,
    /// Forcing periods integrated.
    pub periods: u64,
    /// Another branch of the same model settles elsewhere at this η.
    pub coexisting: bool,
    /// Range of the per-period amplitudes where no steady state was found.
    pub range: Option<AmplitudeRange>,
}

impl FrcRow {
    /// The row's steady state as a [`crate::sim::sweep::Point`] (for the
    /// comparison of branches).
    fn point_value(&self) -> crate::sim::sweep::Point {
        crate::sim::sweep::Point {
            eta: self.eta,
            amplitude1: self.amplitude1,
            amplitude2: self.amplitude2,
            steady: self.steady,
            period_multiple: self.period_multiple,
            stick_fraction: self.stick_fraction,
            interrupted: self.interrupted,
            periods: self.periods,
            method: "",
            range: self.range,
        }
    }

    /// Everything that names the model of the row's curve (not the
    /// direction), as exact bit patterns.
    fn model_key(&self) -> [u64; 11] {
        let o = |v: Option<f64>| v.map_or(u64::MAX, f64::to_bits);
        [
            self.m.to_bits(),
            self.k.to_bits(),
            self.damping.to_bits(),
            self.rho_s.to_bits(),
            self.rho_d.to_bits(),
            self.slope.to_bits(),
            o(self.v_s),
            o(self.stop_below),
            o(self.rho_s_minus),
            o(self.rho_d_minus),
            o(self.contact_stiffness),
        ]
    }
}

/// Sets `coexisting` on every row: true where another branch of the same
/// model at the same η (bit-identical) settles to a different state.
pub fn mark_coexisting(rows: &mut [FrcRow]) {
    use std::collections::HashMap;
    let mut groups: HashMap<([u64; 11], u64), Vec<usize>> = HashMap::new();
    for (i, r) in rows.iter().enumerate() {
        groups
            .entry((r.model_key(), r.eta.to_bits()))
            .or_default()
            .push(i);
    }
    let mut flag = vec![false; rows.len()];
    for idx in groups.values() {
        for (a, &i) in idx.iter().enumerate() {
            for &j in &idx[a + 1..] {
                if rows[i].direction != rows[j].direction
                    && crate::sim::sweep::distinct_states(
                        &rows[i].point_value(),
                        &rows[j].point_value(),
                    )
                {
                    flag[i] = true;
                    flag[j] = true;
                }
            }
        }
    }
    for (r, f) in rows.iter_mut().zip(flag) {
        r.coexisting = f;
    }
}

fn fail(path: &Path, what: &str, e: impl std::fmt::Display) -> Error {
    Error::Input {
        path: path.to_path_buf(),
        msg: format!("{what}: {e}"),
    }
}

/// Where a table sits in its family: shard `index`/`count` (1-based, as
/// `sweep --shard K/N` names it) of a family of `curves` × `points` steady
/// states. An unsharded table is shard 1/1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableMeta {
    /// K in K/N, 1 ≤ K ≤ N.
    pub shard: usize,
    /// N in K/N.
    pub shards: usize,
    /// Curves in the whole family.
    pub curves: usize,
    /// η points per curve.
    pub points: usize,
}

const CSV_TAG: &str = "# stickslip sweep table:";

/// One bound of an [`AmplitudeRange`].
type RangeBound = fn(&AmplitudeRange) -> f64;

/// The columns of [`FrcRow::range`], in table order.
const RANGE_COLUMNS: [(&str, RangeBound); 4] = [
    ("amplitude1_min", |g| g.amplitude1_min),
    ("amplitude1_max", |g| g.amplitude1_max),
    ("amplitude2_min", |g| g.amplitude2_min),
    ("amplitude2_max", |g| g.amplitude2_max),
];

impl TableMeta {
    fn pairs(&self) -> Vec<(String, String)> {
        vec![
            (
                "stickslip.shard".into(),
                format!("{}/{}", self.shard, self.shards),
            ),
            ("stickslip.curves".into(), self.curves.to_string()),
            ("stickslip.points".into(), self.points.to_string()),
        ]
    }

    fn csv_line(&self) -> String {
        format!(
            "{CSV_TAG} shard={}/{} curves={} points={}\n",
            self.shard, self.shards, self.curves, self.points
        )
    }

    /// Reads the metadata from key/value pairs; `None` if the shard key is
    /// absent (a table written before the metadata existed).
    fn from_pairs<'a>(
        path: &Path,
        mut get: impl FnMut(&str) -> Option<&'a str>,
    ) -> Result<Option<Self>> {
        let Some(shard) = get("shard") else {
            return Ok(None);
        };
        let bad =
            |what: &str, v: &str| fail(path, "sweep table metadata", format!("bad {what} `{v}`"));
        let (k, n) = shard.split_once('/').ok_or_else(|| bad("shard", shard))?;
        let num = |what: &str, v: &str| v.trim().parse::<usize>().map_err(|_| bad(what, v));
        let meta = TableMeta {
            shard: num("shard", k)?,
            shards: num("shard", n)?,
            curves: num("curves", get("curves").unwrap_or(""))?,
            points: num("points", get("points").unwrap_or(""))?,
        };
        if meta.shard == 0 || meta.shard > meta.shards {
            return Err(bad("shard", shard));
        }
        // Sizes a header claims are bounded before anything is allocated
        // from them (a part claiming shard 1 of 10^12 is refused).
        crate::io::budget::check_family(meta.curves as u64, meta.points as u64, meta.shards as u64)
            .map_err(|e| fail(path, "sweep table metadata", e))?;
        Ok(Some(meta))
    }
}

/// A table read back: its rows and, if it records them, its place in the
/// family.
#[derive(Debug, Clone)]
pub struct Table {
    /// The rows, in file order.
    pub rows: Vec<FrcRow>,
    /// Shard and family size, `None` for a table without them.
    pub meta: Option<TableMeta>,
}

/// Writes the rows to `path` (`.parquet` or `.csv`) with `meta`, atomically.
pub fn write_frc(rows: &[FrcRow], meta: &TableMeta, path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext != "parquet" && ext != "csv" {
        return Err(fail(path, "table", "must be .parquet or .csv"));
    }
    let f = |g: fn(&FrcRow) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let o = |g: fn(&FrcRow) -> Option<f64>| rows.iter().map(g).collect::<Vec<Option<f64>>>();
    let cols = vec![
        Column::new(
            "curve".into(),
            rows.iter().map(|r| r.curve).collect::<Vec<u32>>(),
        ),
        Column::new(
            "point".into(),
            rows.iter().map(|r| r.point).collect::<Vec<u32>>(),
        ),
        Column::new("m".into(), f(|r| r.m)),
        Column::new("k".into(), f(|r| r.k)),
        Column::new("damping".into(), f(|r| r.damping)),
        Column::new("rho_s".into(), f(|r| r.rho_s)),
        Column::new("rho_d".into(), f(|r| r.rho_d)),
        Column::new("slope".into(), f(|r| r.slope)),
        Column::new("v_s".into(), o(|r| r.v_s)),
        Column::new("stop_below".into(), o(|r| r.stop_below)),
        Column::new(
            "direction".into(),
            rows.iter()
                .map(|r| r.direction.as_str())
                .collect::<Vec<&str>>(),
        ),
        Column::new("eta".into(), f(|r| r.eta)),
        Column::new("amplitude1".into(), o(|r| r.amplitude1)),
        Column::new("amplitude2".into(), o(|r| r.amplitude2)),
        Column::new(
            "steady".into(),
            rows.iter().map(|r| r.steady).collect::<Vec<bool>>(),
        ),
        Column::new(
            "period_multiple".into(),
            rows.iter()
                .map(|r| r.period_multiple)
                .collect::<Vec<Option<u32>>>(),
        ),
        Column::new("stick_fraction".into(), f(|r| r.stick_fraction)),
        Column::new(
            "interrupted".into(),
            rows.iter().map(|r| r.interrupted).collect::<Vec<bool>>(),
        ),
        Column::new(
            "method".into(),
            rows.iter()
                .map(|r| r.method.as_str())
                .collect::<Vec<&str>>(),
        ),
        Column::new(
            "periods".into(),
            rows.iter().map(|r| r.periods).collect::<Vec<u64>>(),
        ),
        Column::new(
            "coexisting".into(),
            rows.iter().map(|r| r.coexisting).collect::<Vec<bool>>(),
        ),
    ];
    let mut cols = cols;
    if rows.iter().any(|r| r.rho_s_minus.is_some()) {
        cols.push(Column::new("rho_s_minus".into(), o(|r| r.rho_s_minus)));
        cols.push(Column::new("rho_d_minus".into(), o(|r| r.rho_d_minus)));
    }
    if rows.iter().any(|r| r.contact_stiffness.is_some()) {
        cols.push(Column::new(
            "contact_stiffness".into(),
            o(|r| r.contact_stiffness),
        ));
    }
    for (name, f) in RANGE_COLUMNS {
        cols.push(Column::new(
            name.into(),
            rows.iter()
                .map(|r| r.range.as_ref().map(f))
                .collect::<Vec<Option<f64>>>(),
        ));
    }
    let mut df =
        DataFrame::new(rows.len(), cols).map_err(|e| fail(path, "cannot build the table", e))?;
    let mut out = crate::io::AtomicFile::create(path)?;
    if ext == "parquet" {
        ParquetWriter::new(out.writer())
            .with_key_value_metadata(Some(KeyValueMetadata::from_static(meta.pairs())))
            .finish(&mut df)
            .map_err(|e| fail(path, "cannot write Parquet", e))?;
    } else {
        use std::io::Write;
        out.writer()
            .write_all(meta.csv_line().as_bytes())
            .map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
        CsvWriter::new(out.writer())
            .finish(&mut df)
            .map_err(|e| fail(path, "cannot write CSV", e))?;
    }
    out.commit()
}

/// Reads a Parquet or CSV table (by the extension of `path`) and its
/// [`TableMeta`], if it has one.
fn read_frame(path: &Path) -> Result<(DataFrame, Option<TableMeta>)> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let read = match ext.as_str() {
        "parquet" => {
            let file = std::fs::File::open(path).map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
            let mut reader = ParquetReader::new(file);
            let kvs = reader
                .get_metadata()
                .map_err(|e| fail(path, "cannot read Parquet", e))?
                .key_value_metadata()
                .clone()
                .unwrap_or_default();
            let meta = TableMeta::from_pairs(path, |key| {
                kvs.iter()
                    .find(|kv| kv.key.strip_prefix("stickslip.") == Some(key))
                    .and_then(|kv| kv.value.as_deref())
            })?;
            let df = reader
                .finish()
                .map_err(|e| fail(path, "cannot read Parquet", e))?;
            (df, meta)
        }
        "csv" => {
            let meta = read_csv_meta(path)?;
            let df = CsvReadOptions::default()
                .with_has_header(true)
                .with_infer_schema_length(None)
                .map_parse_options(|o| o.with_comment_prefix(Some("#")))
                .try_into_reader_with_file_path(Some(path.to_path_buf()))
                .and_then(|r| r.finish())
                .map_err(|e| fail(path, "cannot read CSV", e))?;
            (df, meta)
        }
        _ => return Err(fail(path, "table", "must be .parquet or .csv")),
    };
    Ok(read)
}

/// Whether the existing file at `path` looks like a sweep table (its
/// first line or its Parquet schema names the `curve`, `point` and `eta`
/// columns), read without loading it: `sweep --out` replaces such a table
/// but refuses to replace anything else (a rig log) without `--force`.
pub fn is_sweep_table(path: &Path) -> bool {
    use std::io::{BufRead, Read};
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let has = |names: &[&str]| ["curve", "point", "eta"].iter().all(|c| names.contains(c));
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("csv") => {
            let mut r = std::io::BufReader::new(file).take(8192);
            let mut line = String::new();
            loop {
                line.clear();
                match r.read_line(&mut line) {
                    Ok(0) | Err(_) => return false,
                    Ok(_) if line.starts_with('#') => continue,
                    Ok(_) => {
                        let names: Vec<&str> = line.trim_end().split(',').map(str::trim).collect();
                        return has(&names);
                    }
                }
            }
        }
        Some("parquet") => {
            let mut reader = ParquetReader::new(file);
            match reader.schema() {
                Ok(schema) => {
                    let names: Vec<&str> = schema.iter_names().map(|n| n.as_str()).collect();
                    has(&names)
                }
                Err(_) => false,
            }
        }
        _ => false,
    }
}

/// The [`TableMeta`] of a CSV table's leading comment line, if it has one.
fn read_csv_meta(path: &Path) -> Result<Option<TableMeta>> {
    use std::io::{BufRead, Read};
    let file = std::fs::File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut first = String::new();
    // A first line longer than this is not our comment; read no further.
    std::io::BufReader::new(file)
        .take(4096)
        .read_line(&mut first)
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let Some(rest) = first.trim_end().strip_prefix(CSV_TAG) else {
        return Ok(None);
    };
    let fields: Vec<(&str, &str)> = rest
        .split_whitespace()
        .filter_map(|f| f.split_once('='))
        .collect();
    TableMeta::from_pairs(path, |key| {
        fields.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    })
}

/// The columns of a sweep table read from `path`, cast to their types.
struct Columns<'a> {
    df: &'a DataFrame,
    path: &'a Path,
}

impl Columns<'_> {
    fn get(&self, name: &str, dt: DataType) -> Result<Series> {
        let path = self.path;
        let c = self.df.column(name).map_err(|_| {
            fail(
                path,
                "not a stickslip sweep table",
                format!("no column `{name}`"),
            )
        })?;
        c.as_materialized_series()
            .cast(&dt)
            .map_err(|e| fail(path, &format!("column `{name}`"), e))
    }

    fn fcol(&self, name: &str) -> Result<Vec<Option<f64>>> {
        Ok(self
            .get(name, DataType::Float64)?
            .f64()
            .map_err(|e| fail(self.path, name, e))?
            .iter()
            .collect())
    }

    fn ucol(&self, name: &str) -> Result<Vec<Option<u64>>> {
        Ok(self
            .get(name, DataType::UInt64)?
            .u64()
            .map_err(|e| fail(self.path, name, e))?
            .iter()
            .collect())
    }

    fn bcol(&self, name: &str) -> Result<Vec<Option<bool>>> {
        Ok(self
            .get(name, DataType::Boolean)?
            .bool()
            .map_err(|e| fail(self.path, name, e))?
            .iter()
            .collect())
    }

    fn scol(&self, name: &str) -> Result<Vec<Option<String>>> {
        Ok(self
            .get(name, DataType::String)?
            .str()
            .map_err(|e| fail(self.path, name, e))?
            .iter()
            .map(|s| s.map(str::to_string))
            .collect())
    }
}

/// Reads a table written by [`write_frc`]: its rows and metadata.
pub fn read_table(path: &Path) -> Result<Table> {
    let (df, meta) = read_frame(path)?;
    Ok(Table {
        rows: rows_of(&df, path)?,
        meta,
    })
}

/// Reads the rows of a table written by [`write_frc`].
pub fn read_frc(path: &Path) -> Result<Vec<FrcRow>> {
    read_table(path).map(|t| t.rows)
}

fn rows_of(df: &DataFrame, path: &Path) -> Result<Vec<FrcRow>> {
    let n = df.height();
    let cols = Columns { df, path };
    let fcol = |name: &str| cols.fcol(name);
    let ucol = |name: &str| cols.ucol(name);
    let bcol = |name: &str| cols.bcol(name);
    let scol = |name: &str| cols.scol(name);
    let need = |v: Option<f64>, name: &str, i: usize| {
        v.ok_or_else(|| {
            fail(
                path,
                &format!("row {}", i + 1),
                format!("`{name}` is empty"),
            )
        })
    };
    let (curve, point, periods) = (ucol("curve")?, ucol("point")?, ucol("periods")?);
    let (m, k, d, rs, rd, sl, vs, sb) = (
        fcol("m")?,
        fcol("k")?,
        fcol("damping")?,
        fcol("rho_s")?,
        fcol("rho_d")?,
        fcol("slope")?,
        fcol("v_s")?,
        fcol("stop_below")?,
    );
    let (dir, eta, a1, a2, st, pm, sf, it, me) = (
        scol("direction")?,
        fcol("eta")?,
        fcol("amplitude1")?,
        fcol("amplitude2")?,
        bcol("steady")?,
        ucol("period_multiple")?,
        fcol("stick_fraction")?,
        bcol("interrupted")?,
        scol("method")?,
    );
    // Optional: tables written before the column existed read as false.
    let co = if df.column("coexisting").is_ok() {
        bcol("coexisting")?
    } else {
        vec![None; n]
    };
    // Optional: the levels of a direction-dependent law (absent: symmetric).
    let (rsm, rdm) = if df.column("rho_s_minus").is_ok() {
        (fcol("rho_s_minus")?, fcol("rho_d_minus")?)
    } else {
        (vec![None; n], vec![None; n])
    };
    // Optional: a contact spring (absent: the rigid stick).
    let kappa = if df.column("contact_stiffness").is_ok() {
        fcol("contact_stiffness")?
    } else {
        vec![None; n]
    };
    // Optional: tables written before the range existed read as None.
    let mut range_cols = Vec::with_capacity(RANGE_COLUMNS.len());
    for (name, _) in RANGE_COLUMNS {
        range_cols.push(if df.column(name).is_ok() {
            fcol(name)?
        } else {
            vec![None; n]
        });
    }
    let mut rows = Vec::with_capacity(n);
    for i in 0..n {
        let idx = |v: Option<u64>, name: &str| {
            v.and_then(|x| u32::try_from(x).ok())
                .ok_or_else(|| fail(path, &format!("row {}", i + 1), format!("bad `{name}`")))
        };
        rows.push(FrcRow {
            curve: idx(curve[i], "curve")?,
            point: idx(point[i], "point")?,
            m: need(m[i], "m", i)?,
            k: need(k[i], "k", i)?,
            damping: need(d[i], "damping", i)?,
            rho_s: need(rs[i], "rho_s", i)?,
            rho_d: need(rd[i], "rho_d", i)?,
            slope: need(sl[i], "slope", i)?,
            v_s: vs[i],
            stop_below: sb[i],
            rho_s_minus: rsm[i],
            rho_d_minus: rdm[i],
            contact_stiffness: kappa[i],
            direction: dir[i].clone().unwrap_or_default(),
            eta: need(eta[i], "eta", i)?,
            amplitude1: a1[i],
            amplitude2: a2[i],
            steady: st[i].unwrap_or(false),
            period_multiple: pm[i].and_then(|x| u32::try_from(x).ok()),
            stick_fraction: need(sf[i], "stick_fraction", i)?,
            interrupted: it[i].unwrap_or(false),
            method: me[i].clone().unwrap_or_default(),
            periods: periods[i].unwrap_or(0),
            coexisting: co[i].unwrap_or(false),
            range: range_cols
                .iter()
                .map(|c| c[i])
                .collect::<Option<Vec<f64>>>()
                .map(|v| AmplitudeRange {
                    amplitude1_min: v[0],
                    amplitude1_max: v[1],
                    amplitude2_min: v[2],
                    amplitude2_max: v[3],
                }),
        });
    }
    Ok(rows)
}
