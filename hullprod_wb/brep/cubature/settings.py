"""The integrated quantities and the constants of the cubature's steps, with their meaning
(hullprod_wb.brep.cubature)."""
import numpy as np

from .gauss_rules import XK, piece_weights


#: Names of the integrated quantities, in the order of the value arrays.
QUANTITIES = ("A", "A_valid", "int_abs_K", "int_K_plus", "int_K_minus",
              "A_flat", "A_single", "A_elliptic", "A_saddle")


NQ = len(QUANTITIES)


#: Positions in the value arrays: the area, the K integrals (int |K|, int K+, int K-) and
#: the class areas (flat, single, elliptic, saddle; in a block of them, CLASS_FLAT ...).
AREA = QUANTITIES.index("A")
ABS_K = QUANTITIES.index("int_abs_K")
K_INTEGRALS = slice(QUANTITIES.index("int_abs_K"), QUANTITIES.index("int_K_minus") + 1)
CLASS_AREAS = slice(QUANTITIES.index("A_flat"), NQ)
CLASS_FLAT, CLASS_SINGLE, CLASS_ELLIPTIC, CLASS_SADDLE = range(4)


#: Quantities integrated on lines in mixed cells (K integrals and class areas), and
#: the number of level functions whose crossings cut the lines.
LINE_Q = slice(K_INTEGRALS.start, CLASS_AREAS.stop)


N_LINE_Q = LINE_Q.stop - LINE_Q.start


N_LEVELS = 5


#: The quantities before the class areas: integrated on the quadtree alone.
N_SMOOTH = CLASS_AREAS.start


#: The same positions within the LINE_Q columns of line values.
LINE_K = slice(K_INTEGRALS.start - LINE_Q.start, K_INTEGRALS.stop - LINE_Q.start)
LINE_CLASSES = slice(CLASS_AREAS.start - LINE_Q.start, N_LINE_Q)


#: Quantities below this fraction of their natural scale (A, tau_K A) count as zero.
ZERO_SCALE = 1e-2


#: The quadtree's own acceptance uses this fraction of the tolerances of the smooth
#: quantities (cheap to refine; their error then stays well inside rtol).
TREE_SAFETY = 1e-2


#: Cells accepted on their own Gauss sums may use this fraction of the tolerances: their
#: estimate is the error of the embedded lower-degree rule (degree 2o - 1 against o - 2 per
#: direction), itself a large overestimate of the Gauss rule's error on smooth integrands.
OWN_SAFETY = 0.1


#: Part of the remaining error budget a level may use up by accepting cells.
ACCEPT_FRACTION = 0.5


#: Widening of a cell's sampled K (H) range when testing whether it meets a level.
STRADDLE_MARGIN = 0.5


#: Relative precision of level crossings on a line (of the line's parameter range), and
#: the most steps spent on one (every step is a field call for all of them): a near-double
#: crossing (a level curve almost tangent to the line, where the two crossings bound a
#: sliver of vanishing area) converges only like bisection and may end within 2^-14 of its
#: sample interval.
CROSSING_RTOL = 1e-12


CROSSING_STEPS = 14


#: Parabolic-interpolation steps locating the extremum of a level function along a line.
PARABOLIC_STEPS = 3


#: A dip of three samples is searched for crossings when the vertex of their parabola gets
#: within this fraction of the middle sample's value from zero.
DIP_FRACTION = 0.2


#: Relative precision of a tangency cut in sigma (a cut off by d leaves an error ~ d^1.5),
#: and the most steps spent on finding one.
TANGENT_RTOL = 1e-6


TANGENT_STEPS = 10


#: Crossings of K = 0 (a kink of |K|, max(+-K, 0)) lie inside the band |K| <= tau_K, in flat
#: or single pieces of the lines, where the K integrals are bounded by tau_K times the area.
#: The lines are not cut there while the bounds charged to the K integrals' error estimates
#: instead (lines.line_values; a part ZERO_CHARGE_PARTS of the bound to |K|, K+, K-)
#: stay within ZERO_CHARGE_SHARE of their tolerances; beyond that K = 0 is resolved.
#: The bound of |K| on a line is at most ZERO_BOUND_SAFETY times its largest sampled |K|.
ZERO_CHARGE_SHARE = 0.1


ZERO_CHARGE_PARTS = np.array([1.0, 0.5, 0.5])


ZERO_BOUND_SAFETY = 2.0


#: Line pieces are not halved further once halving keeps this much of their error, nor in a
#: cell that holds this many pieces (the quadtree refines such cells instead).
STALL_RATIO = 0.45


MAX_PIECES = 64

#: Under a point budget, the last level's lines of the field are computed in chunks, largest
#: error first, sized by the points left at LINE_MARGIN times a cell's measured cost and at
#: most doubling; a face's first chunk is 1/LINE_CHUNKS^2 of them
#: (Integration._lines_within_budget).
LINE_CHUNKS = 8
#: Safety on the cost of a cell's lines when a chunk is sized (the cost varies between cells).
LINE_MARGIN = 2.0


#: A mixed cell's lines are taken on its local interpolant (see lines.interpolants)
#: when the interpolant's error estimate is within this share of the cell's budget.
INTERPOLANT_SHARE = 0.1


#: A face of at least GROUP_MIN_PATCHES boundary-fitted patches is integrated as GROUPS
#: ranges of consecutive patches, each an adaptive integration of its own (as separate
#: faces are), which processes can share (see patch_groups).
GROUPS = 2


GROUP_MIN_PATCHES = 256


#: An integration starts from at least MIN_INITIAL_CELLS cells: the patches, halved in both
#: directions as often as needed (at most to one level above max_depth; the levels so
#: skipped count as done, so max_depth keeps its meaning: levels below the patches). Each
#: quadtree level whose cells are integrated on lines costs a pass of several milliseconds
#: whatever its number of cells, and a cell of a quarter of a curved face or more is hardly
#: ever accepted: on a face of one to a few patches the first levels cost such passes for a
#: handful of cells.
MIN_INITIAL_CELLS = 16

#: The 2:1 balance on jumps (balance.unbalanced): an accepted unit is refined again beside a
#: cell four or more times smaller whose samples next to the shared edge exceed BALANCE_JUMP
#: times the largest |K| J the unit sampled, where that cell's |K| integral is at least
#: BALANCE_SHARE of the |K| integral's tolerance.
BALANCE_JUMP = 16.0
BALANCE_SHARE = 1e-3


#: Cells a step of NodePrefetch evaluates (a few milliseconds).
PREFETCH_CELLS = 256


#: Number of candidate cells of largest |K| J kept for the singular-point audit.
N_PEAKS = 10


#: At most this many non-regular sample locations are kept.
MAX_NONREGULAR = 10000


#: Boxes of the deepest accepted cells kept in a result (where the refinement went deepest).
N_DEEPEST = 64


#: Lines of a piece in its parameter: next to each end (for tangency detection only) and
#: at the Kronrod nodes.
EDGE_XI = 1e-5


XI9 = np.concatenate(([EDGE_XI], XK, [1.0 - EDGE_XI]))


#: Samples of a line (fraction of its length): next to the ends (INSIDE: a cell's edge
#: may be a knot line or a box edge where the field jumps; every sample stays in the cell)
#: and at the 3/7 Kronrod nodes. They bracket level crossings and carry the degree-8
#: interpolants of J and K J (degree 6 on the inner 7 for error estimates).
INSIDE = 1e-9


ZS = np.concatenate(([INSIDE], XK, [1.0 - INSIDE]))


#: Pieces of a line shorter than this fraction of it (between nearby crossings) are
#: integrated over the interpolants, without samples of their own.
SHORT_PIECE = 1e-3


#: Pieces of a cell narrower in sigma than this fraction of it (slivers between nearby
#: kinks) are integrated by the 2-point Gauss rule on lines at XI3 (nodes, then midpoint).
SLIVER = 1e-3


XI3 = np.array([0.5 - 0.5 / np.sqrt(3.0), 0.5, 0.5 + 0.5 / np.sqrt(3.0)])


M_HI = piece_weights(ZS)


M_LO = piece_weights(ZS[1:-1])


#: Field row (SegmentField: 0 J, 1 K, 2 H) of each level function of pieces.LineSetting.thresholds:
#: K = +-tau_K (LEVEL_K), H = +-tau_H (LEVEL_H), K = 0.
LEVEL_ROW = np.array([1, 1, 2, 2, 1])
LEVEL_K = slice(0, 2)
LEVEL_H = slice(2, 4)
