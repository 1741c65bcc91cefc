//! The settings' parsers under random values: every settings map and every order text either
//! resolves and renders a frame, or is refused with an error naming the setting; never a panic.

mod common;

use antumbra_core::render::Renderer;
use antumbra_core::settings::{NamedSettings, SettingValue, SCHEMA};
use proptest::prelude::*;

/// Order texts built from the grammar's words with random parameter values.
fn order_text() -> impl Strategy<Value = String> {
    let int = prop_oneof![
        Just(0i64),
        Just(1),
        Just(2),
        Just(64),
        Just(300),
        -3i64..100_000
    ];
    let share = prop_oneof![Just(0.0f64), Just(1.0), Just(-0.5), Just(2.0), 0.0f64..1.5];
    let size = (0u32..5000, 0u32..5000).prop_map(|(w, h)| format!("{w}x{h}"));
    // A share as a number or a percentage ("5%").
    let budget = prop_oneof![
        share.clone().prop_map(|f| f.to_string()),
        (-5i64..150).prop_map(|p| format!("{p}%")),
        Just("NaN".to_string()),
    ];
    let sorted = (
        prop_oneof![
            Just(""),
            Just(":logging=sato"),
            Just(":logging=fbto"),
            Just(":p=area"),
            Just(":p=1"),
            Just(":logging=fbto:p=1"),
        ],
        proptest::option::of(int.clone()),
        proptest::option::of(budget),
    )
        .prop_map(|(l, d, b)| {
            let mut t = format!("sorted{l}");
            if let Some(d) = d {
                t += &format!(":depth={d}");
            }
            if let Some(b) = b {
                t += &format!(":budget={b}");
            }
            t
        });
    let srdh = (
        proptest::option::of(prop_oneof![size.clone(), share.prop_map(|f| f.to_string())]),
        proptest::option::of(int.clone()),
        proptest::option::of(int.clone()),
        proptest::option::of(0.0f64..1.5),
        proptest::option::of(prop_oneof![
            Just("all"),
            Just("constant"),
            Just("directional"),
            Just("none")
        ]),
    )
        .prop_map(|(rays, bins, leaf, occ, kernels)| {
            let mut t = "srdh".to_string();
            if let Some(r) = rays {
                t += &format!(":rays={r}");
            }
            if let Some(b) = bins {
                t += &format!(":bins={b}");
            }
            if let Some(l) = leaf {
                t += &format!(":leaf={l}");
            }
            if let Some(o) = occ {
                t += &format!(":min_occluded={o}");
            }
            if let Some(k) = kernels {
                t += &format!(":kernels={k}");
            }
            t
        });
    prop_oneof![
        Just("stored".to_string()),
        Just("fbto".to_string()),
        Just("sato".to_string()),
        Just("rtsah".to_string()),
        Just("near".to_string()),
        // An option an order does not take, and options in no key=value form.
        Just("sato:depth=3".to_string()),
        Just("sorted:depth".to_string()),
        Just("srdh::bins=8".to_string()),
        int.prop_map(|s| format!("random:seed={s}")),
        sorted,
        srdh,
    ]
}

/// A value for each setting, often of its own type and near or past its range.
fn value_for(i: usize) -> BoxedStrategy<SettingValue> {
    let name = SCHEMA[i].name;
    let texts = match name {
        "order" => order_text().boxed(),
        "visibility" => prop_oneof![
            Just("previous".to_string()),
            Just("exact".to_string()),
            (0u32..5000, 0u32..5000).prop_map(|(w, h)| format!("prepass:{w}x{h}")),
        ]
        .boxed(),
        _ => "[a-z]{0,6}".boxed(),
    };
    prop_oneof![
        any::<bool>().prop_map(SettingValue::Bool),
        prop_oneof![-2i64..300, Just(i64::MAX), Just(u32::MAX as i64)].prop_map(SettingValue::Int),
        prop_oneof![-1.0f64..2.0, Just(f64::NAN), Just(1e30)].prop_map(SettingValue::Float),
        texts.prop_map(SettingValue::Text),
        // Words the choice settings take.
        prop_oneof![
            Just("sah"),
            Just("osah"),
            Just("sbvh"),
            Just("srdh"),
            Just("greedy"),
            Just("all"),
            Just("paper"),
            Just("on"),
            Just("only")
        ]
        .prop_map(SettingValue::from),
    ]
    .boxed()
}

fn settings_map() -> impl Strategy<Value = NamedSettings> {
    proptest::collection::vec(
        (0..SCHEMA.len()).prop_flat_map(|i| (Just(i), value_for(i))),
        0..5,
    )
    .prop_map(|pairs| {
        let mut n = NamedSettings::new();
        for (i, v) in pairs {
            n.insert(SCHEMA[i].name, v);
        }
        n
    })
}

/// A settings value small enough to render a tiny frame quickly.
fn cheap(n: &NamedSettings) -> bool {
    n.get("spp").is_none_or(|v| v.as_int() <= 64)
}

/// A command-line word for setting `i` (`--leaf-size WORD`): its own kind of value near and past
/// its range, or other text.
fn flag_text(i: usize) -> BoxedStrategy<String> {
    let own = value_for(i).prop_map(|v| v.to_string());
    prop_oneof![
        3 => own,
        1 => prop_oneof![
            Just("4294967296".to_string()),
            Just("-0".to_string()),
            Just(" 3".to_string()),
            Just("1e400".to_string()),
            Just("inf".to_string()),
            Just("".to_string()),
            "[ -~]{0,12}",
        ],
    ]
    .boxed()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    /// The CLI's path (`--order sorted:depth=0`, `--build srdh`, `--bins 1`): each flag's word is
    /// parsed alone, then the flags together resolve and render, or the error names the setting.
    #[test]
    fn any_flag_words_render_or_name_their_setting(
        flags in proptest::collection::vec(
            (0..SCHEMA.len()).prop_flat_map(|i| (Just(i), flag_text(i))),
            1..4,
        )
    ) {
        let mut named = NamedSettings::new();
        for (i, text) in &flags {
            let spec = &SCHEMA[*i];
            match spec.parse(text) {
                Ok(v) => named.insert(spec.name, v),
                Err(e) => prop_assert!(
                    e.to_string().starts_with(&format!("{}:", spec.name)),
                    "--{} {text:?}: {e}", spec.name
                ),
            }
        }
        match named.resolve() {
            Ok(settings) => {
                if cheap(&named) {
                    let scene = common::boxes_scene(12);
                    let r = Renderer::new().render("fuzz", &scene, &settings);
                    prop_assert!(r.is_ok(), "{flags:?}: {:?}", r.err());
                }
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(
                    named.0.keys().any(|k| msg.starts_with(&format!("{k}:"))),
                    "{flags:?}: the error names no given setting: {msg}"
                );
            }
        }
    }

    #[test]
    fn any_settings_map_resolves_and_renders_or_names_its_fault(n in settings_map()) {
        match n.resolve() {
            Ok(settings) => {
                if cheap(&n) {
                    let scene = common::boxes_scene(12);
                    let r = Renderer::new().render("fuzz", &scene, &settings);
                    prop_assert!(r.is_ok(), "{n:?}: {:?}", r.err());
                }
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(
                    n.0.keys().any(|k| msg.starts_with(&format!("{k}:"))),
                    "{n:?}: the error names no given setting: {msg}"
                );
            }
        }
    }

    #[test]
    fn any_order_text_renders_or_is_refused_naming_the_order(text in order_text()) {
        let n = NamedSettings::new().with("order", text.as_str()).with("width", 8i64);
        match n.resolve() {
            Ok(settings) => {
                let scene = common::boxes_scene(12);
                let r = Renderer::new().render("fuzz", &scene, &settings);
                prop_assert!(r.is_ok(), "{text}: {:?}", r.err());
            }
            Err(e) => prop_assert!(e.to_string().starts_with("order:"), "{text}: {e}"),
        }
    }
}
