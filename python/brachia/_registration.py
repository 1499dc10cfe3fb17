"""Registration of the Gymnasium environments, done on ``import brachia`` when Gymnasium is installed.

Gymnasium is optional: without it ``import brachia`` works as before and ``brachia.envs`` raises an
ImportError that says what to install.
"""

import importlib.util

ENV_ID = "brachia/Swing-v0"


def register_envs() -> bool:
    """Register ``brachia/Swing-v0`` (single and vector entry points); False without Gymnasium."""
    if importlib.util.find_spec("gymnasium") is None:
        return False
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(
            id=ENV_ID,
            entry_point="brachia.envs:SwingEnv",
            vector_entry_point="brachia.vector:SwingVectorEnv",
        )
    return True
