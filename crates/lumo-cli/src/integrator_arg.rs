//! `--integrator` values read from the tables that define them: lumo-render's
//! [`Integrator`] table (`lumo render`, `lumo bench`) and the wire protocol's modes, which add
//! `both` (`lumo serve`). `--help` lists each value with its description, and a wrong value is
//! answered with the list, as clap does for its own enumerations.

use std::ffi::OsStr;

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use lumo_render::Integrator;

/// A clap value parser over a fixed list of named values.
#[derive(Clone, Copy)]
pub struct NamedParser<T: 'static> {
    all: &'static [T],
    name: fn(T) -> &'static str,
    help: fn(T) -> String,
}

impl<T: Copy + Send + Sync + 'static> NamedParser<T> {
    fn values(&self) -> impl Iterator<Item = PossibleValue> + '_ {
        self.all
            .iter()
            .map(|&v| PossibleValue::new((self.name)(v)).help((self.help)(v)))
    }
}

impl<T: Copy + Send + Sync + 'static> TypedValueParser for NamedParser<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<T, clap::Error> {
        let name = PossibleValuesParser::new(self.values()).parse_ref(cmd, arg, value)?;
        self.all
            .iter()
            .copied()
            .find(|&v| (self.name)(v) == name)
            .ok_or_else(|| clap::Error::new(clap::error::ErrorKind::InvalidValue).with_cmd(cmd))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(self.values()))
    }
}

/// The integrators of lumo-render's table (`lumo render --integrator`, `lumo bench`).
pub fn integrators() -> NamedParser<Integrator> {
    NamedParser {
        all: &Integrator::ALL,
        name: Integrator::name,
        help: |i| i.info().description.to_owned(),
    }
}

/// The server's integrator modes (`lumo serve --integrator`): the table's integrators that
/// feed a sample stream, and `both`.
pub fn serve_integrators() -> NamedParser<lumo_server::Integrator> {
    NamedParser {
        all: lumo_server::Integrator::ALL,
        name: lumo_server::Integrator::name,
        help: |i| match i.parts() {
            [one] => one.info().description.to_owned(),
            parts => {
                let labels: Vec<&str> = parts.iter().map(|p| p.info().label).collect();
                format!(
                    "The {} together, each weighted 1/{}",
                    labels.join(" and "),
                    parts.len()
                )
            }
        },
    }
}

/// The refusal of `--spectral` with an integrator that transports RGB: `modes` are the names
/// the command offers and whether each is spectral.
pub fn spectral_refusal(modes: &[(&str, bool)]) -> String {
    let join = |spectral: bool, word: &str| {
        let names: Vec<&str> = modes
            .iter()
            .filter(|m| m.1 == spectral)
            .map(|m| m.0)
            .collect();
        lumo_render::sentence(&names, word)
    };
    let tracers: Vec<&str> = Integrator::ALL
        .into_iter()
        .filter(|i| i.caps().spectral)
        .map(|i| i.info().label)
        .collect();
    format!(
        "--spectral: spectral transport runs in the {}; use --integrator {} ({} transport RGB)",
        tracers.join(" and "),
        join(true, "or"),
        join(false, "and")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every value parses back to itself, and a wrong one lists the right ones.
    #[test]
    fn every_listed_value_parses_and_a_wrong_one_is_refused() {
        let cmd = clap::Command::new("t");
        let p = integrators();
        for i in Integrator::ALL {
            assert_eq!(p.parse_ref(&cmd, None, OsStr::new(i.name())).ok(), Some(i));
        }
        let err = p.parse_ref(&cmd, None, OsStr::new("both")).unwrap_err();
        assert!(err.to_string().contains("bdpt"), "{err}");
        let s = serve_integrators();
        for i in lumo_server::Integrator::ALL {
            assert_eq!(s.parse_ref(&cmd, None, OsStr::new(i.name())).ok(), Some(*i));
        }
    }

    /// The refusal names the spectral modes and the RGB ones, as it did when written out.
    #[test]
    fn the_spectral_refusal_names_both_sides() {
        let render: Vec<(&str, bool)> = Integrator::ALL
            .iter()
            .map(|i| (i.name(), i.caps().spectral))
            .collect();
        assert_eq!(
            spectral_refusal(&render),
            "--spectral: spectral transport runs in the path tracer and light tracer; use \
             --integrator path or light (bdpt and ppm transport RGB)"
        );
    }
}
