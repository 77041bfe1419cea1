//! Pictures of results (PNG/SVG): not implemented yet.
