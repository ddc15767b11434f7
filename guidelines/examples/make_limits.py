# Documents at and just past motivml's limits.
import os


def nested_model(path, n):
    """n features, each one inside the previous one's "sub" array.

    Every feature but the last adds two levels of JSON nesting (its object and its
    "sub" array), so the last feature's object is at level 2 * n - 1.
    """
    with open(path, "w") as out:
        for i in range(n - 1):
            out.write(f'{{"id": "f{i}", "name": "F{i}", "sub": [')
        out.write(f'{{"id": "f{n - 1}", "name": "F{n - 1}"}}')
        out.write("]}" * (n - 1))


os.makedirs("/tmp/motivml-limits", exist_ok=True)
nested_model("/tmp/motivml-limits/deep_ok.json", 5000)  # 9,999 levels: within the limit
nested_model("/tmp/motivml-limits/deep.json", 5001)  # 10,001 levels: one past it

# A one-feature model whose x- note makes the file just larger than 64 MiB.
with open("/tmp/motivml-limits/big.json", "w") as out:
    out.write('{"id": "root_feature", "name": "Big", "x-note": "')
    out.write("x" * (64 * 1024 * 1024))
    out.write('"}')
