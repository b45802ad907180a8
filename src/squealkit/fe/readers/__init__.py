"""Readers of FE matrices as Abaqus, ANSYS and Nastran export them, with their node and DOF labels."""
