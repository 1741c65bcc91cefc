//! The method settings' flags (`--build`, `--leaf-size`, ...), made from the core settings schema:
//! one flag per setting, with the schema's help, range and default, so a setting added to the
//! schema is on the command line without a change here.

use antumbra_core::render::RenderSettings;
use antumbra_core::settings::{Kind, NamedSettings, Setting, SettingValue, SCHEMA};
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};

/// The settings given on the command line; the rest take their defaults.
#[derive(Clone, Debug, Default)]
pub struct MethodArgs {
    pub named: NamedSettings,
}

impl MethodArgs {
    /// The checked settings.
    pub fn settings(&self) -> anyhow::Result<RenderSettings> {
        Ok(self.named.resolve()?)
    }
}

fn flag(name: &str) -> String {
    name.replace('_', "-")
}

fn negated(name: &str) -> String {
    format!("no_{name}")
}

fn arg_for(s: &'static Setting) -> Arg {
    let help = format!(
        "{} [{}; default: {}]",
        s.help,
        s.expected(),
        s.default_value()
    );
    let arg = Arg::new(s.name)
        .long(flag(s.name))
        .help(help)
        .value_parser(move |text: &str| s.parse(text))
        .action(ArgAction::Set);
    match s.kind {
        // `--spatial-splits` alone is true; `--no-spatial-splits` is false.
        Kind::Bool => arg
            .value_name("BOOL")
            .num_args(0..=1)
            .default_missing_value("true"),
        // `--timing` alone is `on`.
        Kind::Choice(words) if words.contains(&"on") => arg
            .value_name(words.join("|"))
            .num_args(0..=1)
            .default_missing_value("on"),
        Kind::Choice(words) => arg.value_name(words.join("|")),
        Kind::Text { .. } => arg.value_name("SPEC"),
        _ => arg.value_name("N"),
    }
}

impl Args for MethodArgs {
    fn augment_args(cmd: Command) -> Command {
        let mut cmd = cmd.next_help_heading("Method settings");
        for s in SCHEMA {
            cmd = cmd.arg(arg_for(s));
            if s.kind == Kind::Bool {
                cmd = cmd.arg(
                    Arg::new(negated(s.name))
                        .long(flag(&negated(s.name)))
                        .help(format!("The same as --{} false.", flag(s.name)))
                        .action(ArgAction::SetTrue)
                        .conflicts_with(s.name),
                );
            }
        }
        cmd
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl FromArgMatches for MethodArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let mut args = MethodArgs::default();
        args.update_from_arg_matches(m)?;
        Ok(args)
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        for s in SCHEMA {
            if let Some(v) = m.get_one::<SettingValue>(s.name) {
                self.named.insert(s.name, v.clone());
            }
            if s.kind == Kind::Bool && m.get_flag(&negated(s.name)) {
                self.named.insert(s.name, false);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        method: MethodArgs,
    }

    fn parse(args: &[&str]) -> Result<RenderSettings, String> {
        let cli = Cli::try_parse_from(std::iter::once("antumbra").chain(args.iter().copied()))
            .map_err(|e| e.to_string())?;
        cli.method.settings().map_err(|e| e.to_string())
    }

    #[test]
    fn every_setting_has_a_flag() {
        let cmd = <Cli as clap::CommandFactory>::command();
        for s in SCHEMA {
            let long = flag(s.name);
            assert!(
                cmd.get_arguments()
                    .any(|a| a.get_long() == Some(long.as_str())),
                "--{long}"
            );
        }
    }

    #[test]
    fn flags_set_their_settings() {
        let s = parse(&[
            "--build",
            "osah",
            "--osah-w",
            "0.5",
            "--leaf-size",
            "4",
            "--no-spatial-splits",
            "--width",
            "8",
            "--order",
            "sorted:budget=0.1",
            "--timing",
        ])
        .unwrap();
        assert_eq!(
            s.build,
            antumbra_core::render::Pick::Fixed(antumbra_core::build::BuildMethod::Osah)
        );
        assert_eq!(s.build_settings.osah_weight, 0.5);
        assert_eq!(s.build_settings.max_leaf_size, 4);
        assert!(!s.build_settings.spatial.enabled);
        assert_eq!(s.width.get(), 8);
        assert_eq!(
            s.shadow_order.to_string(),
            "sorted:logging=sato:p=1:budget=0.1"
        );
        assert_eq!(s.stats, antumbra_core::render::StatsMode::CountsAndTiming);
        assert_eq!(parse(&[]).unwrap(), RenderSettings::default());
        assert!(
            parse(&["--spatial-splits"])
                .unwrap()
                .build_settings
                .spatial
                .enabled
        );
    }

    #[test]
    fn bad_values_are_named_when_parsed() {
        let e = parse(&["--spp", "0"]).unwrap_err();
        assert!(e.contains("--spp") && e.contains("1..=4096"), "{e}");
        let e = parse(&["--order", "sideways"]).unwrap_err();
        assert!(e.contains("--order") && e.contains("sideways"), "{e}");
        let e = parse(&["--min-leaf-size", "9"]).unwrap_err();
        assert!(
            e.contains("min_leaf_size") && e.contains("leaf_size (8)"),
            "{e}"
        );
        let e = parse(&["--build", "srdh", "--order", "sato"]).unwrap_err();
        assert!(e.contains("sato"), "{e}");
    }
}
