//! Residual-material (scallop) simulation of a milling result: not implemented yet.
