//! Scene model.
