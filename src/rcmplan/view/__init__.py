"""The browser 3D view of rcmplan: replay a run (`rcmplan view RUN_DIR`) and drive the needle
live (`rcmplan view --live`), served by viser (extra `view`).

Nothing here imports viser at module level: `import rcmplan` stays light, and the modules that
need it import it where used (`rcmplan.view.server.viser_module`).
"""
