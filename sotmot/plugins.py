"""The name tables of sotmot's plug-ins: solvers, re-ID backends, detectors.

A leaf module: it imports nothing, so that the configuration and the command
line can validate a name (and list the valid ones) without importing any
plug-in or its heavy dependencies. Each entry maps the name a user writes
(``--solver``, ``[appearance] backend``, ``[detection] backend``) to
``"module:callable"``; the packages that own the plug-ins import the callable
only when it is asked for. Adding a plug-in is one module plus one line here.
"""

#: Long-term association solvers: CLI name -> "module:function" (``sotmot.solvers.get_solver``).
SOLVERS: dict[str, str] = {
    "greedy": "sotmot.solvers.greedy:solve",
    "flow": "sotmot.solvers.mincostflow:solve",
    "flow-nx": "sotmot.solvers.networkx_flow:solve",
    "flow-staged": "sotmot.solvers.mincostflow:solve_staged",
    "lifted": "sotmot.solvers.lifted:solve",
}

#: Re-ID backends: config name -> "module:factory", the factory taking an AppearanceConfig.
BACKENDS: dict[str, str] = {
    "onnx": "sotmot.appearance.onnx:OnnxReidEmbedder",
    "torch": "sotmot.appearance.torch:TorchReidEmbedder",
    "openvino": "sotmot.appearance.openvino:OpenVinoReidEmbedder",
    "none": "sotmot.appearance.none:NoAppearance",
}

#: Person detectors: config name -> "module:factory", the factory taking a DetectionConfig.
DETECTORS: dict[str, str] = {
    "openvino": "sotmot.detection.openvino:OpenVinoDetector",
}

#: The extra that installs what each optional backend or detector imports.
EXTRAS: dict[str, str] = {"torch": "'sotmot[torch]' (torch==2.13.0 and onnx)",
                          "openvino": "openvino (a dependency of sotmot)"}
