"""The finite element side of squealkit: DOF maps, meshes and readers of industrial FE exports."""
