"""Draw docs/img/frames.png: the device, vehicle and earth (level) frames, and three mounts of a phone.

Each panel is in vehicle coordinates (x forward, y left, z up). The phone's axes are the columns of the mount's
inverse, ``M^T e_i`` for ``v_vehicle = M v_device``, taken from :mod:`spotfree.signal.mount` (the nominal mount and
the ``upright`` preset) so the figure shows what the code uses. The last panel shows a vehicle pitched nose-up by a
braking lean against the earth-fixed level frame (z against gravity, x the heading on the horizontal).

Run: ``PYTHONPATH=src python scripts/frames_figure.py [OUT.png]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from spotfree.signal.frame import MOUNT  # noqa: E402
from spotfree.signal.mount import PRESETS  # noqa: E402

DEVICE_COLOURS = ("#d7263d", "#2e933c", "#3a86ff")
PHONE = np.array([[-0.35, -0.7, 0.0], [0.35, -0.7, 0.0], [0.35, 0.7, 0.0], [-0.35, 0.7, 0.0]])
"""The phone's outline in device coordinates (x right, y up along the screen, z out of the screen)."""
PHONE_AT = np.array([0.0, -0.55, 0.45])
"""Where the phone is drawn, in vehicle coordinates (apart from the vehicle's axes, so that parallel arrows show)."""


def axes_arrows(ax, frame: np.ndarray, names, colours, origin=(0.0, 0.0, 0.0), length=1.0, style="-"):
    """Arrows along the rows of ``frame`` (unit vectors in the panel's coordinates), labelled ``names``."""
    for vector, name, colour in zip(frame, names, colours):
        end = np.asarray(origin) + length * vector
        ax.quiver(*origin, *(length * vector), color=colour, linestyle=style, arrow_length_ratio=0.12, linewidth=2)
        ax.text(*(end + 0.08 * vector), name, color=colour, fontsize=10, ha="center", va="center")


def mount_panel(ax, title: str, mount: np.ndarray) -> None:
    """The vehicle axes and the phone on ``mount`` (``v_vehicle = mount @ v_device``)."""
    axes_arrows(ax, np.eye(3), ("x forward", "y left", "z up"), ("black",) * 3, length=1.2)
    corners = PHONE @ mount.T + PHONE_AT
    ax.add_collection3d(Poly3DCollection([corners], facecolor="#8ecae6", edgecolor="#55606a", alpha=0.5))
    axes_arrows(ax, mount.T, ("x", "y", "z"), DEVICE_COLOURS, origin=PHONE_AT, length=0.75)
    ax.set_title(title, fontsize=10)


def level_panel(ax, pitch: float) -> None:
    """The earth (level) frame and a vehicle pitched by ``pitch`` (rad, positive nose down: here negative)."""
    axes_arrows(ax, np.eye(3), ("x level", "y level", "z level (up)"), ("#777777",) * 3, length=1.3, style="--")
    body = Rotation.from_euler("y", pitch).as_matrix()  # vehicle axes written in the level frame
    axes_arrows(ax, body.T, ("x", "y", "z"), ("black",) * 3, length=1.0)
    ax.quiver(0.6, 0.0, 1.1, 0.0, 0.0, -0.6, color="#f49d37", arrow_length_ratio=0.2, linewidth=2)
    ax.text(0.75, 0.0, 0.55, "g", color="#f49d37", fontsize=11)
    ax.set_title(f"vehicle leaning back {np.degrees(-pitch):.0f}° (braking)\nin the earth (level) frame",
                 fontsize=10)


def main(out: Path) -> None:
    turned = MOUNT @ Rotation.from_euler("z", 35, degrees=True).as_matrix().T
    fig = plt.figure(figsize=(13, 3.6))
    panels = [("flat on the handlebar, top edge forward\n(nominal mount)", MOUNT),
              ("upright in a holder, screen to the rider\n(--mount upright)", PRESETS["upright"]),
              ("flat, turned 35° on the handlebar\n(estimated from GPS speed changes)", turned)]
    for k, (title, mount) in enumerate(panels):
        mount_panel(fig.add_subplot(1, 4, k + 1, projection="3d"), title, np.asarray(mount, dtype=float))
    level_panel(fig.add_subplot(1, 4, 4, projection="3d"), np.radians(-12.0))
    for ax in fig.axes:
        ax.set_xlim(-1, 1)
        ax.set_ylim(-1, 1)
        ax.set_zlim(-1, 1)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=22, azim=-125)
        ax.set_axis_off()
    fig.text(0.5, 0.02, "black: vehicle frame (x forward, y left, z up); colour: the phone's device frame (Android: "
             "x right, y up the screen, z out of the screen)", ha="center", fontsize=10)
    fig.subplots_adjust(left=0, right=1, bottom=0.06, top=0.9, wspace=0)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110, bbox_inches="tight")
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent / "docs" / "img" /
         "frames.png")
