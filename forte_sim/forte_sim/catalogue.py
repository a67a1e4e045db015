"""Catalogue of the simulated objects and calibration indentors, with parameter provenance.

The paper's grasp benchmark uses 31 object types in 4 categories (fragile / rigid 7,
fragile / deformable 7, slippery 9, everyday 8, the everyday ones from the YCB set). The
paper names some of them (raspberry, potato chip, raw egg, chocolate ball, blueberry, grape,
tomato, marshmallow, hard-boiled egg, Pringles can, Pocky box, metal bottle, tomato soup
can, apple, jam jar, Nutella jar); the others are plausible stand-ins, stated as such.

Provenance key used in :attr:`ObjectSpec.provenance`:

- ``paper``: number taken or derived from the FORTE paper (apple weight 2.27 N, jam jar
  1.42 N, apple / jam jar theta_zeroF and theta_grasp ranges).
- ``ycb``: mass and dimensions from the YCB object set's published object list
  (Calli et al. 2015).
- ``typical``: typical retail / household value (package label, common size), rounded.
- ``literature``: order of magnitude from food-texture or friction literature (fruit
  firmness and rupture force, egg shell strength, rubber-on-glass / rubber-on-metal friction).
- ``estimate``: our estimate, chosen so that the paper's qualitative outcome is plausible
  (0.25 N enough for light fragile objects, too little for most slippery / everyday ones,
  an On-Off full close breaking or crushing most fragile ones but holding the others).
  ``wrap_gain`` (the vertical support the fin-ray adds by wrapping around curved objects)
  is always an estimate, fitted for the apple and the jam jar to the paper's theta_grasp.
"""
from __future__ import annotations

from dataclasses import dataclass

#: Category names, in the order of the paper's table.
CATEGORIES = ('fragile_rigid', 'fragile_deformable', 'slippery', 'everyday')


@dataclass(frozen=True)
class ObjectSpec:
    """Physical parameters of one object type.

    Attributes
    ----------
    name : str
        snake_case object type name.
    category : str
        One of :data:`CATEGORIES`.
    mass : float
        Mass [kg].
    width : float
        Width across the grasp line (distance between the two contact points at zero
        force) [m]. theta_zeroF = width / gap-per-radian of the gripper.
    height : float
        Height of the object along the lift direction [m]; limits how far the fingers can
        slide along it before contact is lost.
    shape : str
        ``'round'`` (width shrinks as the contact slides away from the grasp line) or
        ``'straight'`` (constant width: cans, boxes, bottles).
    mu_static, mu_kinetic : float
        Static and kinetic friction coefficients against the fingers' EPU 40 surface [-].
        A small difference (< 0.03) means smooth sliding without stick-slip.
    wrap_gain : float
        Multiplier (>= 1) of the friction capacity from the fin-ray wrapping around a
        curved object (contact normals tilted upward) [-].
    stiffness : float or None
        Local contact stiffness of the object at each finger [N/mm]; None = rigid.
    break_force : float or None
        Normal force per finger above which the object fails [N]; None = not fragile.
    failure : str or None
        ``'broken'`` (fragile rigid) or ``'crushed'`` (fragile deformable); None if robust.
    com_offset : float
        Largest centre-of-mass offset from the grasp axis [m]; the trial draws |e| in
        [0, com_offset]. Gravity torque m g e drives rotational slip.
    taper_angle : float
        Inclination of the contact normals that squeezes the object out of the grasp
        (ovoid grasped off its equator) [rad]; 0 for most objects.
    contact_location : float
        Nominal contact location along the finger, 0 = fingertip, 1 = root [-].
    torsion_radius : float
        Effective radius of the contact patch for torsional friction [m].
    provenance : str
        Where the numbers come from (see the module docstring).
    """

    name: str
    category: str
    mass: float
    width: float
    height: float
    shape: str
    mu_static: float
    mu_kinetic: float
    wrap_gain: float = 1.0
    stiffness: float | None = None
    break_force: float | None = None
    failure: str | None = None
    com_offset: float = 0.003
    taper_angle: float = 0.0
    contact_location: float = 0.4
    torsion_radius: float = 0.008
    provenance: str = 'estimate'


def _spec(*args, **kwargs) -> ObjectSpec:
    return ObjectSpec(*args, **kwargs)


_OBJECT_LIST: tuple[ObjectSpec, ...] = (
    # ---------------- fragile / rigid (7) ----------------
    _spec('raw_egg', 'fragile_rigid', 0.060, 0.044, 0.057, 'round', 0.45, 0.35, wrap_gain=2.0,
          break_force=30.0, failure='broken', com_offset=0.006, contact_location=0.35,
          torsion_radius=0.006,
          provenance='mass/size typical (large egg); shell failure ~30 N literature; '
                     'friction, wrap estimate'),
    _spec('chocolate_ball', 'fragile_rigid', 0.0125, 0.030, 0.030, 'round', 0.55, 0.40,
          wrap_gain=1.8, break_force=12.0, failure='broken', contact_location=0.25,
          provenance='mass/size typical (hazelnut praline); break force estimate'),
    _spec('potato_chip', 'fragile_rigid', 0.0025, 0.050, 0.045, 'straight', 0.60, 0.45,
          break_force=1.5, failure='broken', contact_location=0.2, torsion_radius=0.004,
          provenance='mass typical; snap force 1-3 N literature (chip texture tests)'),
    _spec('saltine_cracker', 'fragile_rigid', 0.003, 0.050, 0.050, 'straight', 0.65, 0.50,
          break_force=2.5, failure='broken', contact_location=0.25,
          provenance='mass/size typical; break force estimate'),
    _spec('meringue', 'fragile_rigid', 0.005, 0.035, 0.030, 'round', 0.70, 0.50,
          wrap_gain=1.3, break_force=1.2, failure='broken', contact_location=0.2,
          provenance='estimate'),
    _spec('wafer_roll', 'fragile_rigid', 0.006, 0.016, 0.110, 'straight', 0.60, 0.45,
          break_force=2.0, failure='broken', contact_location=0.15,
          provenance='mass/size typical; break force estimate'),
    _spec('ice_cream_cone', 'fragile_rigid', 0.010, 0.050, 0.110, 'straight', 0.65, 0.50,
          break_force=3.0, failure='broken', contact_location=0.3,
          provenance='mass/size typical (waffle cone); break force estimate'),
    # ---------------- fragile / deformable (7) ----------------
    _spec('raspberry', 'fragile_deformable', 0.004, 0.022, 0.022, 'round', 0.80, 0.60,
          wrap_gain=1.5, stiffness=0.15, break_force=0.6, failure='crushed',
          contact_location=0.15, torsion_radius=0.005,
          provenance='mass/size typical; firmness and crush force literature order '
                     '(soft berries < 1 N); stiffness estimate'),
    _spec('blueberry', 'fragile_deformable', 0.0015, 0.014, 0.012, 'round', 0.70, 0.55,
          wrap_gain=1.5, stiffness=0.30, break_force=0.7, failure='crushed',
          contact_location=0.1, torsion_radius=0.004,
          provenance='mass/size typical; firmness 0.2-0.4 N/mm literature; crush estimate'),
    _spec('grape', 'fragile_deformable', 0.005, 0.020, 0.022, 'round', 0.55, 0.40,
          wrap_gain=1.5, stiffness=0.50, break_force=1.2, failure='crushed',
          contact_location=0.15, provenance='mass/size typical; crush force estimate'),
    _spec('cherry_tomato', 'fragile_deformable', 0.015, 0.028, 0.028, 'round', 0.55, 0.40,
          wrap_gain=1.6, stiffness=0.80, break_force=2.0, failure='crushed',
          contact_location=0.2, provenance='mass/size typical; firmness literature order'),
    _spec('marshmallow', 'fragile_deformable', 0.007, 0.035, 0.030, 'straight', 0.90, 0.70,
          stiffness=0.05, break_force=0.4, failure='crushed', contact_location=0.25,
          provenance='mass/size typical (large marshmallow); stiffness, set force estimate'),
    _spec('strawberry', 'fragile_deformable', 0.020, 0.030, 0.040, 'round', 0.70, 0.50,
          wrap_gain=1.5, stiffness=0.40, break_force=1.5, failure='crushed',
          contact_location=0.25, provenance='mass/size typical; bruise force estimate'),
    _spec('button_mushroom', 'fragile_deformable', 0.015, 0.035, 0.035, 'round', 0.60, 0.45,
          wrap_gain=1.4, stiffness=1.0, break_force=2.5, failure='crushed',
          contact_location=0.25, provenance='mass/size typical; bruise force estimate'),
    # ---------------- slippery (9) ----------------
    _spec('soda_can', 'slippery', 0.385, 0.066, 0.122, 'straight', 0.40, 0.30,
          contact_location=0.4, torsion_radius=0.010,
          provenance='mass/size of a full 355 ml can typical; friction (lacquered '
                     'aluminium on PU) estimate'),
    _spec('glass_bottle', 'slippery', 0.200, 0.060, 0.230, 'straight', 0.50, 0.38,
          contact_location=0.4, torsion_radius=0.010,
          provenance='empty 330 ml bottle typical; rubber on glass friction literature order'),
    _spec('metal_bottle', 'slippery', 0.250, 0.070, 0.250, 'straight', 0.35, 0.27,
          com_offset=0.010, contact_location=0.4, torsion_radius=0.010,
          provenance='empty steel bottle typical; friction estimate'),
    _spec('jam_jar', 'slippery', 0.145, 0.0647, 0.080, 'straight', 0.90, 0.65,
          wrap_gain=2.5, contact_location=0.3, torsion_radius=0.010,
          provenance='weight 1.42 N and theta_zeroF 0.476 rad from paper; wrap fitted to '
                     "paper's theta_grasp 0.460 rad"),
    _spec('nutella_jar', 'slippery', 0.350, 0.075, 0.100, 'straight', 0.50, 0.38,
          wrap_gain=1.2, contact_location=0.35, torsion_radius=0.010,
          provenance='mass/size typical (200 g jar); friction estimate'),
    _spec('pringles_can', 'slippery', 0.205, 0.075, 0.235, 'straight', 0.45, 0.33,
          com_offset=0.010, contact_location=0.4, torsion_radius=0.010,
          provenance='mass/size ycb (chips can); friction estimate'),
    _spec('pocky_box', 'slippery', 0.045, 0.022, 0.150, 'straight', 0.30, 0.29,
          contact_location=0.3,
          provenance='mass/size typical; glossy card, almost no stick-slip: estimate'),
    _spec('hard_boiled_egg', 'slippery', 0.050, 0.042, 0.055, 'round', 0.15, 0.14,
          wrap_gain=1.5, taper_angle=0.30, com_offset=0.005, contact_location=0.35,
          provenance='mass/size typical; wet peeled egg friction and taper estimate'),
    _spec('glass_ornament', 'slippery', 0.030, 0.060, 0.060, 'round', 0.30, 0.22,
          wrap_gain=2.5, contact_location=0.35, provenance='estimate'),
    # ---------------- everyday (8: apple from the paper, then _YCB_EVERYDAY) ------------
    _spec('apple', 'everyday', 0.231, 0.075, 0.075, 'round', 0.80, 0.60, wrap_gain=3.0,
          stiffness=30.0, com_offset=0.006, contact_location=0.4, torsion_radius=0.012,
          provenance='weight 2.27 N and theta_zeroF 0.552 rad from paper; wrap fitted to '
                     "paper's theta_grasp 0.527 rad; stiffness literature order"),
)

#: The straight-sided everyday objects of the YCB set, mass and size from its object list:
#: name, mass [kg], width [m], height [m], mu_static, mu_kinetic, contact_location [-],
#: torsion_radius [m], com_offset [m], what the friction estimate is based on.
_YCB_EVERYDAY = (
    ('tomato_soup_can', 0.349, 0.066, 0.102, 0.45, 0.32, 0.4, 0.010, 0.003, ''),
    ('mustard_bottle', 0.603, 0.058, 0.190, 0.55, 0.40, 0.4, 0.012, 0.008, ''),
    ('sugar_box', 0.514, 0.038, 0.175, 0.65, 0.50, 0.4, 0.012, 0.003, 'card'),
    ('cracker_box', 0.411, 0.060, 0.210, 0.65, 0.50, 0.4, 0.012, 0.008, 'card'),
    ('pudding_box', 0.187, 0.035, 0.089, 0.65, 0.50, 0.35, 0.010, 0.003, 'card'),
    ('gelatin_box', 0.097, 0.028, 0.073, 0.65, 0.50, 0.3, 0.010, 0.003, 'card'),
    ('potted_meat_can', 0.370, 0.050, 0.083, 0.45, 0.33, 0.4, 0.010, 0.003, ''),
)


def _ycb_everyday(name: str, mass: float, width: float, height: float, mu_static: float,
                  mu_kinetic: float, contact_location: float, torsion_radius: float,
                  com_offset: float, friction_basis: str) -> ObjectSpec:
    """An everyday object of :data:`_YCB_EVERYDAY` (straight-sided box, can or bottle)."""
    friction = f'{friction_basis} friction' if friction_basis else 'friction'
    return ObjectSpec(name, 'everyday', mass, width, height, 'straight', mu_static, mu_kinetic,
                      com_offset=com_offset, contact_location=contact_location,
                      torsion_radius=torsion_radius,
                      provenance=f'mass/size ycb; {friction} estimate')


_OBJECT_LIST += tuple(_ycb_everyday(*row) for row in _YCB_EVERYDAY)

#: Every object type of the grasp benchmark, by name.
OBJECTS: dict[str, ObjectSpec] = {spec.name: spec for spec in _OBJECT_LIST}


@dataclass(frozen=True)
class IndentorSpec:
    """A load-cell indentor of the force calibration rig (rigid, centred in the grasp).

    Attributes
    ----------
    name : str
        Indentor shape name.
    width : float
        Width across the grasp line [m]; sets theta_zeroF.
    contact_location : float
        Where the indentor presses on the finger, 0 = tip, 1 = root [-].
    contact_spread : float
        Extent of the contact along the finger (flat faces press on more of it) [-].
    """

    name: str
    width: float
    contact_location: float
    contact_spread: float


#: The 6 indentor shapes of the calibration rig (paper Fig. 3c; shapes are estimates). The
#: widths make a full close squeeze about 8 N, the paper's force range.
INDENTORS: dict[str, IndentorSpec] = {
    spec.name: spec for spec in (
        IndentorSpec('flat_wide', 0.041, 0.45, 0.45),
        IndentorSpec('flat_narrow', 0.043, 0.35, 0.20),
        IndentorSpec('cylinder_large', 0.045, 0.40, 0.30),
        IndentorSpec('cylinder_small', 0.0465, 0.30, 0.15),
        IndentorSpec('sphere', 0.048, 0.25, 0.12),
        IndentorSpec('edge', 0.050, 0.20, 0.08),
    )
}


def objects_in_category(category: str) -> list[str]:
    """Names of the objects of one category, in catalogue order.

    Parameters
    ----------
    category : str
        One of :data:`CATEGORIES`.

    Returns
    -------
    list of str
        Object names.
    """
    if category not in CATEGORIES:
        raise ValueError(f'unknown category {category!r}; expected one of {CATEGORIES}')
    return [name for name, spec in OBJECTS.items() if spec.category == category]
