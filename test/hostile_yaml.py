"""Hostile YAML shared by the scene and bag tests."""


def billion_laughs(levels: int = 12) -> str:
    """Each level a list of ten aliases of the one before: 10^12 values once expanded."""
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"
