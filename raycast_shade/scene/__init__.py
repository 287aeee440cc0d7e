"""Stage 1, what to render: meshes and their normals, procedural shapes,
materials, height maps, lights, cameras, the scene that packs them, and scene
files. Knows nothing of how the scene is seen or shaded."""
