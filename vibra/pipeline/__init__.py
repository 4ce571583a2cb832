"""The scene-to-report pipeline: scene file -> plan -> report, and sweeps over scenes.

- `scene`: scene files, their schema (derived from the builders) and limits
- `plan`: a scene's plan (the steps to run), the system it builds, and its execution
- `render`: off-screen pyvista renders of mode shapes (the only pyvista importer)
- `report`: batches of scenes into PNG / HTML / JSON reports
- `sweep`: one scene (or builder) solved at many parameter points
"""
