use super::*;

/// `sliding_jet` agrees with `sliding`, `sliding_slope` and a central
/// difference of the slope for every shaped family and a linear law.
#[test]
fn sliding_jet_matches_parts() {
    let mut laws: Vec<Law> = LawKind::all()
        .iter()
        .filter_map(|&k| Law::of(k, 1.0, 0.6, 0.01, Some(0.3)))
        .filter(|l| l.affine().is_none())
        .collect();
    assert!(!laws.is_empty());
    laws.push(Law::Linear {
        rho_s: 1.0,
        rho_d: 0.8,
        slope: -0.02,
        minus: None,
    });
    for law in laws {
        for v in [0.0, 0.05, 0.2, 0.3, 0.7, 2.0] {
            let (g, g1, g2) = law.sliding_jet(v);
            assert!((g - law.sliding(v)).abs() <= 1e-15, "{law:?} {v}");
            assert!((g1 - law.sliding_slope(v)).abs() <= 1e-15, "{law:?} {v}");
            let (e, sl) = (1e-6, |v: f64| law.sliding_slope(v));
            let fd = if v >= e {
                (sl(v + e) - sl(v - e)) / (2.0 * e)
            } else {
                (sl(v + e) - sl(v)) / e
            };
            assert!(
                (g2 - fd).abs() <= 1e-4 * (1.0 + g2.abs()),
                "{law:?} {v}: {g2} vs {fd}"
            );
            // g(0+) = ρs for a shaped law.
            if law.affine().is_none() {
                assert!((law.sliding(0.0) - law.rho_s()).abs() <= 1e-15, "{law:?}");
            }
        }
    }
}

/// Every family: its name parses back, serialises as its name, and its
/// parameter vector survives unpack/pack; names are unique; the SI sliding
/// friction agrees with the dimensionless one.
#[test]
fn kinds_round_trip_through_names_serde_and_families() {
    let names: std::collections::BTreeSet<&str> =
        LawKind::all().iter().map(|k| k.as_str()).collect();
    assert_eq!(names.len(), LawKind::all().len());
    let rig = RigConstants::paper();
    let s = Scales::from_rig(&rig, 0.002);
    for &k in LawKind::all() {
        assert_eq!(LawKind::parse(k.as_str()), Some(k));
        let json = serde_json::to_string(&k).unwrap();
        assert_eq!(json, format!("\"{}\"", k.as_str()));
        assert_eq!(serde_json::from_str::<LawKind>(&json).unwrap(), k);
        let f = k.family();
        let p: Vec<f64> = (0..f.params().len()).map(|i| 1.0 + i as f64).collect();
        assert_eq!(f.pack(&f.unpack(&p)), p, "{k}");
        assert_eq!(f.unpack(&p).kind, k);
        assert!(!f.describe().is_empty());
        let si = f.synth_law(1.2, 0.9, None, 0.01);
        assert_eq!(si.kind, k);
        let rho = si.to_rho(&s).expect("physical");
        assert_eq!(rho.kind(), k, "{k}");
        for u in [0.0, 0.003, 0.01, 0.05] {
            let v = u / s.velocity_m_per_s;
            let g = rho.sliding(v) * s.force_n;
            assert!(
                (g - si.sliding_n(u)).abs() <= 1e-12 * (1.0 + g.abs()),
                "{k} {u}"
            );
        }
    }
    assert!(serde_json::from_str::<LawKind>("\"static_dynamic\"").is_err());
}

#[test]
fn to_rho_scales_each_parameter() {
    let rig = RigConstants::paper();
    let s = Scales::from_rig(&rig, 0.002);
    let l = SiLaw {
        kind: LawKind::Stribeck,
        rs_n: 1.0,
        rd_n: 0.5,
        slope_n_s_per_m: 0.3,
        vs_m_per_s: Some(0.01),
    };
    let Some(Law::Shaped {
        kind,
        rho_s,
        rho_d,
        slope,
        v_s,
        minus: None,
    }) = l.to_rho(&s)
    else {
        panic!("not a shaped law")
    };
    assert_eq!(kind, LawKind::Stribeck);
    let (k2, m2) = (rig.k2_n_per_m, rig.m2_kg);
    assert!((rho_s - 1.0 / (0.002 * k2)).abs() < 1e-12);
    assert!((rho_d - 0.5 / (0.002 * k2)).abs() < 1e-12);
    assert!((slope - 0.3 / (k2 * m2).sqrt()).abs() < 1e-12);
    assert!((v_s - 0.01 / (0.002 * (k2 / m2).sqrt())).abs() < 1e-12);
    let unknown = SiLaw {
        rs_n: f64::NAN,
        ..l
    };
    assert_eq!(unknown.to_rho(&s), None);
    // A shaped family without its velocity scale is no law (it used to
    // fall through to a linear one).
    let no_vs = SiLaw {
        vs_m_per_s: None,
        ..l
    };
    assert_eq!(no_vs.to_rho(&s), None);
}

#[test]
fn law_names() {
    assert_eq!(Law::coulomb(0.3).name(), "coulomb");
    assert_eq!(
        Law::Linear {
            rho_s: 0.3,
            rho_d: 0.3,
            slope: -0.04,
            minus: None,
        }
        .name(),
        "decreasing"
    );
    assert_eq!(
        Law::Linear {
            rho_s: 0.3,
            rho_d: 0.15,
            slope: 0.0,
            minus: None,
        }
        .name(),
        "static-dynamic"
    );
}

#[test]
fn the_scale_column_is_the_only_one_that_depends_on_the_velocity_scale() {
    for &k in LawKind::all() {
        let f = k.family();
        assert_eq!(f.scale_column().is_some(), f.has_velocity_scale(), "{k:?}");
        for (s, u) in [(1.0, 3e-3), (-1.0, 4e-4), (1.0, 0.02)] {
            let (a, na) = f.basis(s, u, 0.7, -0.2, 1e-3);
            let (b, nb) = f.basis(s, u, 0.7, -0.2, 5e-3);
            assert_eq!(na, nb);
            for c in 0..na {
                if Some(c) == f.scale_column() {
                    assert_ne!(a[c], b[c], "{k:?} column {c}");
                } else {
                    assert_eq!(a[c], b[c], "{k:?} column {c}");
                }
            }
        }
    }
}
