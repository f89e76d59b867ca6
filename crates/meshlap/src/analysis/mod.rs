//! Matrix-theoretic analysis of operators.
