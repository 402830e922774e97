//! `segment`'s parameter flags, made from the library's parameter table (`PARAMETERS`): one
//! `--FLAG VALUE` per parameter with its documentation as the help, each value checked against
//! the parameter's range as it is parsed. `threads` is the global `--threads`.

use balloonseg::balloon::params::{Parameter, PARAMETERS};
use balloonseg::balloon::BalloonParams;
use clap::{Arg, ArgMatches, Command, FromArgMatches};

/// The global flag that gives this parameter.
const GLOBAL: &str = "threads";

/// The parameters given on the command line, each already checked.
#[derive(Debug, Default)]
pub struct ParamFlags {
    given: Vec<(&'static Parameter, f64)>,
}

impl ParamFlags {
    /// The defaults with the given values and `threads` set.
    pub fn params(&self, threads: usize) -> balloonseg::Result<BalloonParams> {
        let mut params = BalloonParams {
            threads,
            ..BalloonParams::default()
        };
        for &(p, value) in &self.given {
            p.set(&mut params, value)?;
        }
        Ok(params)
    }
}

fn flags() -> impl Iterator<Item = &'static Parameter> {
    PARAMETERS.iter().filter(|p| p.flag != GLOBAL)
}

fn help(p: &Parameter) -> String {
    let default = match p.unset {
        Some(unset) => format!("default: {unset}"),
        None => format!("default: {}", p.default_value()),
    };
    format!("{} [{}; {}]", p.doc, p.range_text(), default)
}

impl clap::Args for ParamFlags {
    fn augment_args(mut command: Command) -> Command {
        for p in flags() {
            command = command.arg(
                Arg::new(p.flag)
                    .long(p.flag)
                    .value_name("VALUE")
                    .allow_negative_numbers(true)
                    .help(help(p))
                    .value_parser(move |text: &str| -> Result<f64, String> {
                        let value: f64 = text
                            .trim()
                            .parse()
                            .map_err(|e| format!("'{text}' is not a number: {e}"))?;
                        p.check(value).map_err(|e| e.message().to_string())?;
                        Ok(value)
                    }),
            );
        }
        command
    }

    fn augment_args_for_update(command: Command) -> Command {
        Self::augment_args(command)
    }
}

impl FromArgMatches for ParamFlags {
    fn from_arg_matches(matches: &ArgMatches) -> Result<Self, clap::Error> {
        let mut flags = ParamFlags::default();
        flags.update_from_arg_matches(matches)?;
        Ok(flags)
    }

    fn update_from_arg_matches(&mut self, matches: &ArgMatches) -> Result<(), clap::Error> {
        for p in flags() {
            if let Some(&value) = matches.get_one::<f64>(p.flag) {
                self.given.retain(|(q, _)| q.name != p.name);
                self.given.push((p, value));
            }
        }
        Ok(())
    }
}
