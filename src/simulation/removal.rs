//! Belt-grinding material-removal simulation (Hamann model): not implemented yet.
