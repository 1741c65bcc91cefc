use super::*;
use crate::build::{BuildMethod, CollapseMethod, SpatialAxes};
use crate::order::ShadowOrder;
use crate::render::Pick;

fn named(pairs: &[(&str, SettingValue)]) -> NamedSettings {
    NamedSettings(
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect(),
    )
}

#[test]
fn names_are_unique_snake_case_and_helped() {
    let mut seen = std::collections::BTreeSet::new();
    for s in SCHEMA {
        assert!(seen.insert(s.name), "{} twice", s.name);
        assert!(
            s.name.chars().all(|c| c.is_ascii_lowercase() || c == '_'),
            "{}",
            s.name
        );
        assert!(!s.help.is_empty() && s.help.len() < 400, "{}", s.name);
    }
}

#[test]
fn every_default_is_valid_and_survives_a_round_trip() {
    let d = RenderSettings::default();
    for s in SCHEMA {
        s.check(&s.default_value())
            .unwrap_or_else(|e| panic!("default of {}: {e}", s.name));
    }
    assert_eq!(d.to_named().resolve().unwrap(), d);
    assert_eq!(NamedSettings::new().resolve().unwrap(), d);
}

/// A value other than the default for each setting, to show each one reaches its field.
fn other_value(s: &Setting) -> SettingValue {
    let d = s.default_value();
    match s.kind {
        Kind::Bool => SettingValue::Bool(!d.as_bool()),
        Kind::Int { min, max } => SettingValue::Int(if d.as_int() == min {
            (min + 3).min(max)
        } else {
            min.max(1)
        }),
        Kind::IntChoice(list) => {
            SettingValue::Int(*list.iter().find(|&&i| i != d.as_int()).unwrap())
        }
        Kind::Float { min, max, .. } => {
            SettingValue::Float(if d.as_float() == (min + max.min(1.0)) / 2.0 {
                (min + max.min(1.0)) / 4.0
            } else {
                (min + max.min(1.0)) / 2.0
            })
        }
        Kind::Choice(words) => SettingValue::Text(
            words
                .iter()
                .find(|w| **w != d.as_text())
                .unwrap()
                .to_string(),
        ),
        Kind::Text { .. } => SettingValue::Text(
            match s.name {
                "order" => "sorted:depth=3:budget=0.1",
                "visibility" => "prepass:64x32",
                other => panic!("no test value for text setting {other}"),
            }
            .to_string(),
        ),
    }
}

#[test]
fn each_setting_reaches_its_field_and_reads_back() {
    let d = RenderSettings::default();
    for s in SCHEMA {
        let v = other_value(s);
        let mut map = named(&[(s.name, v.clone())]);
        if s.name == "min_leaf_size" {
            map.insert("leaf_size", 64i64);
        }
        let r = map
            .resolve()
            .unwrap_or_else(|e| panic!("{} = {v}: {e}", s.name));
        // `build=srdh` reads back as the SAH build with the srdh order.
        if s.name == "build" && v.as_text() == "srdh" {
            assert!(matches!(r.shadow_order, Pick::Fixed(ShadowOrder::Srdh(_))));
            continue;
        }
        assert_ne!(r, d, "{} = {v} changed nothing", s.name);
        if !matches!(s.kind, Kind::Text { .. }) {
            assert_eq!((s.get)(&r), v, "{}", s.name);
        }
        assert_eq!(r.to_named().resolve().unwrap(), r, "{}", s.name);
    }
}

#[test]
fn choice_words_are_the_types_own_names() {
    let words = |name: &str| match setting(name).unwrap().kind {
        Kind::Choice(w) => w.to_vec(),
        k => panic!("{name}: {k:?}"),
    };
    let builds = words("build");
    for m in BuildMethod::ALL {
        assert!(builds.contains(&m.name()), "{}", m.name());
    }
    assert_eq!(
        builds.len(),
        BuildMethod::ALL.len() + 2,
        "the builders, srdh and auto"
    );
    assert!(builds.contains(&crate::render::AUTO));
    let collapses = words("collapse");
    assert_eq!(collapses.len(), CollapseMethod::ALL.len());
    for m in CollapseMethod::ALL {
        assert!(collapses.contains(&m.name()));
    }
    for a in [SpatialAxes::All, SpatialAxes::Object] {
        assert!(words("spatial_axes").contains(&a.to_string().as_str()));
    }
}

#[test]
fn errors_name_the_setting_and_what_it_takes() {
    let msg = |pairs: &[(&str, SettingValue)]| named(pairs).resolve().unwrap_err().to_string();
    let m = msg(&[("spp", SettingValue::Bool(true))]);
    assert!(
        m.starts_with("spp:") && m.contains("integer in 1..=4096") && m.contains("boolean"),
        "{m}"
    );
    let m = msg(&[("spd", 4i64.into())]);
    assert!(
        m.starts_with("spd: unknown setting") && m.contains("spp"),
        "{m}"
    );
    let m = msg(&[("osah_w", 1.0f64.into())]);
    assert!(m.starts_with("osah_w:") && m.contains("(0, 1)"), "{m}");
    let m = msg(&[("width", 3i64.into())]);
    assert!(m.starts_with("width:") && m.contains("2, 4, 8"), "{m}");
    let m = msg(&[("bins", 1.5f64.into())]);
    assert!(
        m.starts_with("bins:") && m.contains("a number (1.5)"),
        "{m}"
    );
    let m = msg(&[("collapse", "fast".into())]);
    assert!(
        m.starts_with("collapse:") && m.contains("sah, greedy"),
        "{m}"
    );
    let m = msg(&[("order", "sideways".into())]);
    assert!(m.contains("sideways"), "{m}");
    let m = msg(&[("min_leaf_size", 9i64.into())]);
    assert!(
        m.starts_with("min_leaf_size:") && m.contains("leaf_size (8)"),
        "{m}"
    );
    // An integer where a number is wanted is that number.
    let r = named(&[("traversal_cost", 2i64.into())]).resolve().unwrap();
    assert_eq!(r.build_settings.traversal_cost, 2.0);
}

#[test]
fn command_line_words_parse_to_the_same_values() {
    let p = |name: &str, text: &str| setting(name).unwrap().parse(text);
    assert_eq!(p("spp", "16").unwrap(), SettingValue::Int(16));
    assert_eq!(
        p("spatial_splits", "off").unwrap(),
        SettingValue::Bool(false)
    );
    assert_eq!(p("osah_w", "0.5").unwrap(), SettingValue::Float(0.5));
    assert!(p("spp", "0").unwrap_err().to_string().starts_with("spp:"));
    assert!(p("spp", "many").unwrap_err().to_string().contains("'many'"));
    assert!(p("width", "3").is_err());
}

#[test]
fn build_srdh_is_sah_with_the_srdh_order() {
    let r = named(&[("build", "srdh".into())]).resolve().unwrap();
    assert_eq!(r.build, Pick::Fixed(BuildMethod::Sah));
    assert_eq!(
        r.shadow_order,
        Pick::Fixed(ShadowOrder::Srdh(Default::default()))
    );
    let r = named(&[
        ("build", "srdh".into()),
        ("order", "srdh:rays=32x32".into()),
    ])
    .resolve()
    .unwrap();
    assert_eq!(r.shadow_order, "srdh:rays=32x32".parse().unwrap());
    let m = named(&[("build", "srdh".into()), ("order", "sato".into())])
        .resolve()
        .unwrap_err()
        .to_string();
    assert!(m.starts_with("build:") && m.contains("sato"), "{m}");
    let r = named(&[("build", "sbvh".into()), ("order", "srdh".into())])
        .resolve()
        .unwrap();
    assert_eq!(r.build, Pick::Fixed(BuildMethod::Sbvh));
}

#[test]
fn the_wire_form_is_a_plain_map() {
    let json = r#"{"spp": 16, "build": "osah", "osah_w": 0.5, "spatial_splits": false}"#;
    let n: NamedSettings = serde_json::from_str(json).unwrap();
    let r = n.resolve().unwrap();
    assert_eq!((r.spp, r.build), (16, Pick::Fixed(BuildMethod::Osah)));
    assert_eq!(r.build_settings.osah_weight, 0.5);
    assert!(!r.build_settings.spatial.enabled);
}

#[test]
fn a_value_of_no_setting_type_is_refused_naming_its_setting() {
    let e = serde_json::from_str::<NamedSettings>(r#"{"spp": 4, "order": [1, 2]}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("setting 'order'") && e.contains("a boolean, an integer, a number or text"),
        "{e}"
    );
    let e = serde_json::from_str::<NamedSettings>(r#"{"seed": null}"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("setting 'seed'"), "{e}");
}

#[test]
fn docs_settings_md_is_the_schema() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/settings.md");
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(&path, markdown()).unwrap();
    }
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        text == markdown(),
        "docs/settings.md differs from the schema: run UPDATE_DOCS=1 cargo test -p antumbra-core --lib settings"
    );
}
