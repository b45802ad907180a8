"""Design of brakes against squeal: derivatives of eigenvalues, countermeasures and robust margins."""
