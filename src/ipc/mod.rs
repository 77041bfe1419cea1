//! iceoryx2 zero-copy toolpath output: not implemented yet.
