//! The wire's integrator modes against lumo-render's table: each mode runs table integrators,
//! and each table integrator that feeds a sample stream has its own mode, by the same name.

use super::Integrator;

#[test]
fn every_streaming_table_integrator_maps_to_its_mode_and_back() {
    for t in lumo_render::Integrator::ALL {
        let caps = t.caps();
        let mode = Integrator::from_table(t);
        assert_eq!(
            mode.is_some(),
            caps.camera_stream || caps.light_stream,
            "{t:?}: offered by the server exactly when it feeds a stream"
        );
        if let Some(m) = mode {
            assert_eq!(m.parts(), [t]);
            assert_eq!(m.name(), t.name());
            assert_eq!(m.streams(), [caps.camera_stream, caps.light_stream]);
            assert_eq!(m.renders_media(), caps.media);
        }
    }
    for &m in Integrator::ALL {
        assert!(!m.parts().is_empty(), "{m:?}");
        match m.parts() {
            [one] => assert_eq!(Integrator::from_table(*one), Some(m)),
            // A mode of several integrators has a name of its own.
            many => {
                assert!(
                    lumo_render::Integrator::from_name(m.name()).is_none(),
                    "{m:?}"
                );
                assert!(many.len() > 1);
            }
        }
    }
    assert_eq!(Integrator::Both.streams(), [true, true]);
    assert!(Integrator::Both.spectral() && !Integrator::Bdpt.spectral());
}
