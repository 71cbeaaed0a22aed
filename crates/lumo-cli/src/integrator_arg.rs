//! `--integrator` values read from the tables that define them: lumo-render's
//! [`Integrator`] table (`lumo render`, `lumo bench`) and the wire protocol's modes, which add
//! `both` (`lumo serve`). `--help` lists each value with its description, and a wrong value is
//! answered with the list, as `lumo denoise --filter` does for the filter list.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use lumo_render::Integrator;

/// The integrators of lumo-render's table (`lumo render --integrator`, `lumo bench`).
pub fn integrators() -> impl TypedValueParser<Value = Integrator> {
    let values = Integrator::ALL
        .iter()
        .map(|i| PossibleValue::new(i.name()).help(i.info().description));
    PossibleValuesParser::new(values).map(|name| {
        Integrator::from_name(&name).expect("every possible value is a name from the table")
    })
}

/// The server's integrator modes (`lumo serve --integrator`): the table's integrators that
/// feed a sample stream, and `both`.
pub fn serve_integrators() -> impl TypedValueParser<Value = lumo_server::Integrator> {
    let values = lumo_server::Integrator::ALL.iter().map(|m| {
        let help = match m.parts() {
            [one] => one.info().description.to_owned(),
            parts => {
                let labels: Vec<&str> = parts.iter().map(|p| p.info().label).collect();
                format!(
                    "The {} together, each weighted 1/{}",
                    labels.join(" and "),
                    parts.len()
                )
            }
        };
        PossibleValue::new(m.name()).help(help)
    });
    PossibleValuesParser::new(values).map(|name| {
        *lumo_server::Integrator::ALL
            .iter()
            .find(|m| m.name() == name)
            .expect("every possible value is a name from the wire enum")
    })
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
    use std::ffi::OsStr;

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
        let serve: Vec<(&str, bool)> = lumo_server::Integrator::ALL
            .iter()
            .map(|m| (m.name(), m.spectral()))
            .collect();
        assert!(spectral_refusal(&serve)
            .ends_with("use --integrator path, light or both (bdpt and ppm transport RGB)"));
    }
}
