"""Labelled drawing of the finger for the bench: port face with tube labels, vent face.

Writes a PNG (matplotlib, Agg backend) that shows the port side face (looking at
``y = +width/2``) and the vent side face with every opening labelled with its channel
and the tube label of the tubing map in docs/hardware.md, plus the channel centre lines.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from forte_finger.design import FingerDesign, outer_surface_x  # noqa: E402

COLOURS = {'inner': 'tab:red', 'outer': 'tab:blue'}


def tube_label(channel_name: str) -> str:
    """Tube label without the finger letter, e.g. ``distal_inner`` -> ``D-in``."""
    location, surface = channel_name.split('_')
    return f"{location[0].upper()}-{'in' if surface == 'inner' else 'out'}"


def draw(design: FingerDesign, path: Path) -> None:
    """Write the labelled two-view drawing of ``design`` to ``path`` (PNG)."""
    p = design.parameters
    figure, (port_ax, vent_ax) = plt.subplots(1, 2, figsize=(9, 8))
    outline = np.vstack([design.profile, design.profile[:1]])
    radius = p.channel_radius
    for axis, side, title in ((port_ax, 'port', 'port side (y = +width/2): tubes'),
                              (vent_ax, 'vent', 'vent side (y = -width/2): seal')):
        # seen from outside: the port face is viewed from +y (x to the left), the vent
        # face from -y (x to the right)
        sign = -1.0 if side == 'port' else 1.0
        axis.plot(sign * outline[:, 0], outline[:, 1], 'k', lw=1.2)
        for cell in design.cells:
            loop = np.vstack([cell, cell[:1]])
            axis.fill(sign * loop[:, 0], loop[:, 1], color='0.88')
        for channel in design.channels:
            colour = COLOURS[channel.surface]
            axis.plot(sign * channel.path[:, 0], channel.path[:, 2], color=colour, lw=0.8,
                      ls=':')
            opening = channel.port if side == 'port' else channel.vent
            if opening is None:
                continue
            axis.add_patch(plt.Circle((sign * opening[0], opening[2]), radius,
                                      color=colour))
            if channel.surface == 'inner':  # label beyond the contact surface
                label_x = -sign * 2.5
            else:  # label beyond the outer surface
                label_x = sign * (outer_surface_x(p, float(opening[2])) + 2.5)
            axis.annotate(f'{tube_label(channel.name)}\n{channel.name}',
                          (sign * opening[0], opening[2]), xytext=(label_x, opening[2] - 1.5),
                          fontsize=7, color=colour, ha='left' if label_x > 0 else 'right')
        axis.annotate('contact surface', (0.0, 0.0), xytext=(-sign * 1.0, 2.0), rotation=90,
                      fontsize=8, ha='center')
        axis.set_xlim(*sorted((-sign * 18.0, sign * (p.base_depth + 16.0))))
        axis.set_title(title, fontsize=10)
        axis.set_aspect('equal')
        axis.set_xlabel('x [mm] (0 = contact surface), seen from outside the face')
        axis.set_ylabel('z [mm] (0 = top of mount)')
        axis.grid(True, lw=0.3)
    figure.suptitle('FORTE finger: openings (red = inner channel -> P+, blue = outer -> P-)',
                    fontsize=11)
    figure.tight_layout()
    figure.savefig(path, dpi=110, format='png')
    plt.close(figure)
