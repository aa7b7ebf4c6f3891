/* layouts.cl — GENERATED from mcocl/layouts.py by `python -m mcocl.layouts`; do not edit.
 *
 * The records and codes the host and the kernels share (see mcocl/layouts.py).
 * tests/test_layouts.py checks that this file is what the generator writes and
 * that sizeof/offsetof of every struct match the NumPy dtypes on the device. */
#ifndef MCOCL_LAYOUTS_CL
#define MCOCL_LAYOUTS_CL

/* MaterialKind: ``materials[k].kind``: the BSDF of a material (kernels/render/bsdf.cl). */
#define MAT_DIFFUSE 0
#define MAT_CONDUCTOR 1
#define MAT_ROUGHCONDUCTOR 2
#define MAT_DIELECTRIC 3
#define MAT_PLASTIC 4
#define MAT_ROUGHDIELECTRIC 5
#define MAT_THINDIELECTRIC 6
#define MAT_ROUGHPLASTIC 7

/* Integrator: The render kernel's ``-DINTEGRATOR`` variant (kernels/render/integrator.cl; LT: kernels/render/lt.cl;
    BDPT: kernels/render/bdpt.cl). */
#define INTEGRATOR_PATH 0
#define INTEGRATOR_NEE 1
#define INTEGRATOR_MIS 2
#define INTEGRATOR_LT 3
#define INTEGRATOR_BDPT 4

/* LightShape: ``light_record.shape``: how light sampling places a point on the emitter (kernels/render/lights.cl). */
#define LIGHT_TRIANGLE 0
#define LIGHT_SPHERE 1
#define LIGHT_SPHERE_INWARD 2
#define LIGHT_POINT 3
#define LIGHT_SPOT 4
#define LIGHT_DIRECTIONAL 5

/* LightSampler: The render kernel's ``-DLIGHT_SAMPLER``: how an area light is chosen (kernels/render/lights.cl).

    POWER and UNIFORM share one kernel (a CDF over the lights, built on the
    host, mcocl/render/emitter_choice.py); BVH traverses the light BVH from
    the shading point (kernels/render/light_bvh.cl, mcocl/render/light_bvh.py). */
#define LIGHT_SAMPLER_POWER 0
#define LIGHT_SAMPLER_UNIFORM 1
#define LIGHT_SAMPLER_BVH 2

/* FilmStat: Column of the film's per-pixel statistics (mcocl/render/film.py, kernels/render/integrator.cl). */
#define FILM_SUM_R 0
#define FILM_SUM_G 1
#define FILM_SUM_B 2
#define FILM_SUMSQ_R 3
#define FILM_SUMSQ_G 4
#define FILM_SUMSQ_B 5
#define FILM_SAMPLES 6
#define FILM_NONFINITE 7
#define FILM_STATS 8

/* Bits of material_record.flags (mcocl/bsdf_registry.py, FLAG_BITS). */
#define MAT_FLAG_TWOSIDED 1
#define MAT_FLAG_BECKMANN 2
#define MAT_FLAG_ANISOTROPIC 4
#define MAT_FLAG_COMPLEX_IOR 8
#define MAT_FLAG_TRANSMITTANCE 16
#define MAT_FLAG_ALPHA_GRID 32

/* A field of a float4-stored record gathered by <RECORD>_GATHER(q, ...) into rec4v q0, q1, ...:
 * REC_FIELD(q, PRIM_RECORD_AREA) is q0.w.  The gather macros read `index` once per float4:
 * pass a variable, not a call (a search repeated per float4 cost the render kernel ~7 %). */
#define REC_CAT_(a, b) a##b
#define REC_CAT(a, b) REC_CAT_(a, b)
#define REC_FIELD(q, F) (REC_CAT(q, F##_QUAD).F##_COMP)
/* A float[3] field as a vec3v (render/vec3.cl); REC_FIELD gives its first component. */
#define REC_VEC3(q, F) v3(REC_CAT(q, F##_QUAD).F##_COMP, REC_CAT(q, F##_QUAD).F##_COMP1, \
                      REC_CAT(q, F##_QUAD).F##_COMP2)

/* shading data of primitive p: front normal (0 for spheres), area, material, emitter */
typedef struct {
    float normal[3];
    float area;
    uint material;
    int emitter;
    float pmf;
    float inward;
} prim_record;
#define PRIM_RECORD_QUADS 2u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q1 (render/lane_io.cl's gather_rec4). */
#define PRIM_RECORD_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 2u + 0u), q##1 = gather_rec4((table), (index) * 2u + 1u)
#define PRIM_RECORD_NORMAL_QUAD 0
#define PRIM_RECORD_NORMAL_COMP x
#define PRIM_RECORD_NORMAL_COMP1 y
#define PRIM_RECORD_NORMAL_COMP2 z
#define PRIM_RECORD_AREA_QUAD 0
#define PRIM_RECORD_AREA_COMP w
#define PRIM_RECORD_MATERIAL_QUAD 1
#define PRIM_RECORD_MATERIAL_COMP x
#define PRIM_RECORD_EMITTER_QUAD 1
#define PRIM_RECORD_EMITTER_COMP y
#define PRIM_RECORD_PMF_QUAD 1
#define PRIM_RECORD_PMF_COMP z
#define PRIM_RECORD_INWARD_QUAD 1
#define PRIM_RECORD_INWARD_COMP w

/* emitting primitive k: triangle v0 and edges, or sphere centre and radius */
typedef struct {
    float base[3];
    float area;
    float edge1[3];
    float shape;
    float edge2[3];
    float pmf;
    float radiance[3];
    uint prim;
} light_record;
#define LIGHT_RECORD_QUADS 4u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q3 (render/lane_io.cl's gather_rec4). */
#define LIGHT_RECORD_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 4u + 0u), q##1 = gather_rec4((table), (index) * 4u + 1u), q##2 = gather_rec4((table), (index) * 4u + 2u), q##3 = gather_rec4((table), (index) * 4u + 3u)
#define LIGHT_RECORD_BASE_QUAD 0
#define LIGHT_RECORD_BASE_COMP x
#define LIGHT_RECORD_BASE_COMP1 y
#define LIGHT_RECORD_BASE_COMP2 z
#define LIGHT_RECORD_AREA_QUAD 0
#define LIGHT_RECORD_AREA_COMP w
#define LIGHT_RECORD_EDGE1_QUAD 1
#define LIGHT_RECORD_EDGE1_COMP x
#define LIGHT_RECORD_EDGE1_COMP1 y
#define LIGHT_RECORD_EDGE1_COMP2 z
#define LIGHT_RECORD_SHAPE_QUAD 1
#define LIGHT_RECORD_SHAPE_COMP w
#define LIGHT_RECORD_EDGE2_QUAD 2
#define LIGHT_RECORD_EDGE2_COMP x
#define LIGHT_RECORD_EDGE2_COMP1 y
#define LIGHT_RECORD_EDGE2_COMP2 z
#define LIGHT_RECORD_PMF_QUAD 2
#define LIGHT_RECORD_PMF_COMP w
#define LIGHT_RECORD_RADIANCE_QUAD 3
#define LIGHT_RECORD_RADIANCE_COMP x
#define LIGHT_RECORD_RADIANCE_COMP1 y
#define LIGHT_RECORD_RADIANCE_COMP2 z
#define LIGHT_RECORD_PRIM_QUAD 3
#define LIGHT_RECORD_PRIM_COMP w

/* light BVH node: bounding sphere, cone (axis, cos theta_o), power, children or light */
typedef struct {
    float center[3];
    float radius2;
    float axis[3];
    float cos_o;
    float power;
    uint ref;
    uint count;
    float cos_e;
} light_bvh_node;
#define LIGHT_BVH_NODE_QUADS 3u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q2 (render/lane_io.cl's gather_rec4). */
#define LIGHT_BVH_NODE_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 3u + 0u), q##1 = gather_rec4((table), (index) * 3u + 1u), q##2 = gather_rec4((table), (index) * 3u + 2u)
#define LIGHT_BVH_NODE_CENTER_QUAD 0
#define LIGHT_BVH_NODE_CENTER_COMP x
#define LIGHT_BVH_NODE_CENTER_COMP1 y
#define LIGHT_BVH_NODE_CENTER_COMP2 z
#define LIGHT_BVH_NODE_RADIUS2_QUAD 0
#define LIGHT_BVH_NODE_RADIUS2_COMP w
#define LIGHT_BVH_NODE_AXIS_QUAD 1
#define LIGHT_BVH_NODE_AXIS_COMP x
#define LIGHT_BVH_NODE_AXIS_COMP1 y
#define LIGHT_BVH_NODE_AXIS_COMP2 z
#define LIGHT_BVH_NODE_COS_O_QUAD 1
#define LIGHT_BVH_NODE_COS_O_COMP w
#define LIGHT_BVH_NODE_POWER_QUAD 2
#define LIGHT_BVH_NODE_POWER_COMP x
#define LIGHT_BVH_NODE_REF_QUAD 2
#define LIGHT_BVH_NODE_REF_COMP y
#define LIGHT_BVH_NODE_COUNT_QUAD 2
#define LIGHT_BVH_NODE_COUNT_COMP z
#define LIGHT_BVH_NODE_COS_E_QUAD 2
#define LIGHT_BVH_NODE_COS_E_COMP w

/* a material: its MaterialKind code (as a float) and parameters */
typedef struct {
    float kind;
    float rgb[3];
    float alpha;
    float int_ior;
    float ext_ior;
    float flags;
    float alpha_second;
    float eta_rgb[3];
    float k_rgb[3];
    float table;
    float transmittance_rgb[3];
    float pad;
} material_record;
#define MATERIAL_RECORD_QUADS 5u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q4 (render/lane_io.cl's gather_rec4). */
#define MATERIAL_RECORD_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 5u + 0u), q##1 = gather_rec4((table), (index) * 5u + 1u), q##2 = gather_rec4((table), (index) * 5u + 2u), q##3 = gather_rec4((table), (index) * 5u + 3u), q##4 = gather_rec4((table), (index) * 5u + 4u)
#define MATERIAL_RECORD_KIND_QUAD 0
#define MATERIAL_RECORD_KIND_COMP x
#define MATERIAL_RECORD_RGB_QUAD 0
#define MATERIAL_RECORD_RGB_COMP y
#define MATERIAL_RECORD_RGB_COMP1 z
#define MATERIAL_RECORD_RGB_COMP2 w
#define MATERIAL_RECORD_ALPHA_QUAD 1
#define MATERIAL_RECORD_ALPHA_COMP x
#define MATERIAL_RECORD_INT_IOR_QUAD 1
#define MATERIAL_RECORD_INT_IOR_COMP y
#define MATERIAL_RECORD_EXT_IOR_QUAD 1
#define MATERIAL_RECORD_EXT_IOR_COMP z
#define MATERIAL_RECORD_FLAGS_QUAD 1
#define MATERIAL_RECORD_FLAGS_COMP w
#define MATERIAL_RECORD_ALPHA_SECOND_QUAD 2
#define MATERIAL_RECORD_ALPHA_SECOND_COMP x
#define MATERIAL_RECORD_ETA_RGB_QUAD 2
#define MATERIAL_RECORD_ETA_RGB_COMP y
#define MATERIAL_RECORD_ETA_RGB_COMP1 z
#define MATERIAL_RECORD_ETA_RGB_COMP2 w
#define MATERIAL_RECORD_K_RGB_QUAD 3
#define MATERIAL_RECORD_K_RGB_COMP x
#define MATERIAL_RECORD_K_RGB_COMP1 y
#define MATERIAL_RECORD_K_RGB_COMP2 z
#define MATERIAL_RECORD_TABLE_QUAD 3
#define MATERIAL_RECORD_TABLE_COMP w
#define MATERIAL_RECORD_TRANSMITTANCE_RGB_QUAD 4
#define MATERIAL_RECORD_TRANSMITTANCE_RGB_COMP x
#define MATERIAL_RECORD_TRANSMITTANCE_RGB_COMP1 y
#define MATERIAL_RECORD_TRANSMITTANCE_RGB_COMP2 z
#define MATERIAL_RECORD_PAD_QUAD 4
#define MATERIAL_RECORD_PAD_COMP w

/* perspective camera: origin and the right/up/forward axes (right, up scaled by the fov); thin lens: aperture radius (0: a pinhole) and focus distance; a film crop's centre in the crop's NDC units */
typedef struct {
    float origin[3];
    float aperture_radius;
    float right[3];
    float focus_distance;
    float up[3];
    float crop_shift_x;
    float forward[3];
    float crop_shift_y;
} camera_record;
#define CAMERA_RECORD_QUADS 4u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q3 (render/lane_io.cl's gather_rec4). */
#define CAMERA_RECORD_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 4u + 0u), q##1 = gather_rec4((table), (index) * 4u + 1u), q##2 = gather_rec4((table), (index) * 4u + 2u), q##3 = gather_rec4((table), (index) * 4u + 3u)
#define CAMERA_RECORD_ORIGIN_QUAD 0
#define CAMERA_RECORD_ORIGIN_COMP x
#define CAMERA_RECORD_ORIGIN_COMP1 y
#define CAMERA_RECORD_ORIGIN_COMP2 z
#define CAMERA_RECORD_APERTURE_RADIUS_QUAD 0
#define CAMERA_RECORD_APERTURE_RADIUS_COMP w
#define CAMERA_RECORD_RIGHT_QUAD 1
#define CAMERA_RECORD_RIGHT_COMP x
#define CAMERA_RECORD_RIGHT_COMP1 y
#define CAMERA_RECORD_RIGHT_COMP2 z
#define CAMERA_RECORD_FOCUS_DISTANCE_QUAD 1
#define CAMERA_RECORD_FOCUS_DISTANCE_COMP w
#define CAMERA_RECORD_UP_QUAD 2
#define CAMERA_RECORD_UP_COMP x
#define CAMERA_RECORD_UP_COMP1 y
#define CAMERA_RECORD_UP_COMP2 z
#define CAMERA_RECORD_CROP_SHIFT_X_QUAD 2
#define CAMERA_RECORD_CROP_SHIFT_X_COMP w
#define CAMERA_RECORD_FORWARD_QUAD 3
#define CAMERA_RECORD_FORWARD_COMP x
#define CAMERA_RECORD_FORWARD_COMP1 y
#define CAMERA_RECORD_FORWARD_COMP2 z
#define CAMERA_RECORD_CROP_SHIFT_Y_QUAD 3
#define CAMERA_RECORD_CROP_SHIFT_Y_COMP w

/* nodes[0] of a BVH: primitive count, internal nodes, depth, row of the leaf primitives */
typedef struct {
    uint nprims;
    uint num_nodes;
    uint depth;
    uint leaf_row;
} bvh_header;
#define BVH_HEADER_QUADS 1u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q0 (render/lane_io.cl's gather_rec4). */
#define BVH_HEADER_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 1u + 0u)
#define BVH_HEADER_NPRIMS_QUAD 0
#define BVH_HEADER_NPRIMS_COMP x
#define BVH_HEADER_NUM_NODES_QUAD 0
#define BVH_HEADER_NUM_NODES_COMP y
#define BVH_HEADER_DEPTH_QUAD 0
#define BVH_HEADER_DEPTH_COMP z
#define BVH_HEADER_LEAF_ROW_QUAD 0
#define BVH_HEADER_LEAF_ROW_COMP w

/* internal BVH node: both children's boxes; cnt 0: child is node ref, else leaf prims[ref..ref+cnt) */
typedef struct {
    float lo0[3];
    uint ref0;
    float hi0[3];
    uint cnt0;
    float lo1[3];
    uint ref1;
    float hi1[3];
    uint cnt1;
} bvh_node;
#define BVH_NODE_QUADS 4u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q3 (render/lane_io.cl's gather_rec4). */
#define BVH_NODE_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 4u + 0u), q##1 = gather_rec4((table), (index) * 4u + 1u), q##2 = gather_rec4((table), (index) * 4u + 2u), q##3 = gather_rec4((table), (index) * 4u + 3u)
#define BVH_NODE_LO0_QUAD 0
#define BVH_NODE_LO0_COMP x
#define BVH_NODE_LO0_COMP1 y
#define BVH_NODE_LO0_COMP2 z
#define BVH_NODE_REF0_QUAD 0
#define BVH_NODE_REF0_COMP w
#define BVH_NODE_HI0_QUAD 1
#define BVH_NODE_HI0_COMP x
#define BVH_NODE_HI0_COMP1 y
#define BVH_NODE_HI0_COMP2 z
#define BVH_NODE_CNT0_QUAD 1
#define BVH_NODE_CNT0_COMP w
#define BVH_NODE_LO1_QUAD 2
#define BVH_NODE_LO1_COMP x
#define BVH_NODE_LO1_COMP1 y
#define BVH_NODE_LO1_COMP2 z
#define BVH_NODE_REF1_QUAD 2
#define BVH_NODE_REF1_COMP w
#define BVH_NODE_HI1_QUAD 3
#define BVH_NODE_HI1_COMP x
#define BVH_NODE_HI1_COMP1 y
#define BVH_NODE_HI1_COMP2 z
#define BVH_NODE_CNT1_QUAD 3
#define BVH_NODE_CNT1_COMP w

/* 8-wide BVH node (mcocl/render/bvh_wide.py): its children's boxes as structure of arrays; cnt 0: child is wide node ref, 0xffffffff: no child, else a leaf of cnt leaf records from ref; field f_0 holds children 0-3, f_4 children 4-7 (a float8 is two float4 rows) */
typedef struct {
    float lo_x_0[4];
    float lo_x_4[4];
    float lo_y_0[4];
    float lo_y_4[4];
    float lo_z_0[4];
    float lo_z_4[4];
    float hi_x_0[4];
    float hi_x_4[4];
    float hi_y_0[4];
    float hi_y_4[4];
    float hi_z_0[4];
    float hi_z_4[4];
    uint ref_0[4];
    uint ref_4[4];
    uint cnt_0[4];
    uint cnt_4[4];
} bvh_wide_node;
#define BVH_WIDE_NODE_QUADS 16u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q15 (render/lane_io.cl's gather_rec4). */
#define BVH_WIDE_NODE_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 16u + 0u), q##1 = gather_rec4((table), (index) * 16u + 1u), q##2 = gather_rec4((table), (index) * 16u + 2u), q##3 = gather_rec4((table), (index) * 16u + 3u), q##4 = gather_rec4((table), (index) * 16u + 4u), q##5 = gather_rec4((table), (index) * 16u + 5u), q##6 = gather_rec4((table), (index) * 16u + 6u), q##7 = gather_rec4((table), (index) * 16u + 7u), q##8 = gather_rec4((table), (index) * 16u + 8u), q##9 = gather_rec4((table), (index) * 16u + 9u), q##10 = gather_rec4((table), (index) * 16u + 10u), q##11 = gather_rec4((table), (index) * 16u + 11u), q##12 = gather_rec4((table), (index) * 16u + 12u), q##13 = gather_rec4((table), (index) * 16u + 13u), q##14 = gather_rec4((table), (index) * 16u + 14u), q##15 = gather_rec4((table), (index) * 16u + 15u)
#define BVH_WIDE_NODE_LO_X_0_QUAD 0
#define BVH_WIDE_NODE_LO_X_0_COMP x
#define BVH_WIDE_NODE_LO_X_0_COMP1 y
#define BVH_WIDE_NODE_LO_X_0_COMP2 z
#define BVH_WIDE_NODE_LO_X_0_COMP3 w
#define BVH_WIDE_NODE_LO_X_4_QUAD 1
#define BVH_WIDE_NODE_LO_X_4_COMP x
#define BVH_WIDE_NODE_LO_X_4_COMP1 y
#define BVH_WIDE_NODE_LO_X_4_COMP2 z
#define BVH_WIDE_NODE_LO_X_4_COMP3 w
#define BVH_WIDE_NODE_LO_Y_0_QUAD 2
#define BVH_WIDE_NODE_LO_Y_0_COMP x
#define BVH_WIDE_NODE_LO_Y_0_COMP1 y
#define BVH_WIDE_NODE_LO_Y_0_COMP2 z
#define BVH_WIDE_NODE_LO_Y_0_COMP3 w
#define BVH_WIDE_NODE_LO_Y_4_QUAD 3
#define BVH_WIDE_NODE_LO_Y_4_COMP x
#define BVH_WIDE_NODE_LO_Y_4_COMP1 y
#define BVH_WIDE_NODE_LO_Y_4_COMP2 z
#define BVH_WIDE_NODE_LO_Y_4_COMP3 w
#define BVH_WIDE_NODE_LO_Z_0_QUAD 4
#define BVH_WIDE_NODE_LO_Z_0_COMP x
#define BVH_WIDE_NODE_LO_Z_0_COMP1 y
#define BVH_WIDE_NODE_LO_Z_0_COMP2 z
#define BVH_WIDE_NODE_LO_Z_0_COMP3 w
#define BVH_WIDE_NODE_LO_Z_4_QUAD 5
#define BVH_WIDE_NODE_LO_Z_4_COMP x
#define BVH_WIDE_NODE_LO_Z_4_COMP1 y
#define BVH_WIDE_NODE_LO_Z_4_COMP2 z
#define BVH_WIDE_NODE_LO_Z_4_COMP3 w
#define BVH_WIDE_NODE_HI_X_0_QUAD 6
#define BVH_WIDE_NODE_HI_X_0_COMP x
#define BVH_WIDE_NODE_HI_X_0_COMP1 y
#define BVH_WIDE_NODE_HI_X_0_COMP2 z
#define BVH_WIDE_NODE_HI_X_0_COMP3 w
#define BVH_WIDE_NODE_HI_X_4_QUAD 7
#define BVH_WIDE_NODE_HI_X_4_COMP x
#define BVH_WIDE_NODE_HI_X_4_COMP1 y
#define BVH_WIDE_NODE_HI_X_4_COMP2 z
#define BVH_WIDE_NODE_HI_X_4_COMP3 w
#define BVH_WIDE_NODE_HI_Y_0_QUAD 8
#define BVH_WIDE_NODE_HI_Y_0_COMP x
#define BVH_WIDE_NODE_HI_Y_0_COMP1 y
#define BVH_WIDE_NODE_HI_Y_0_COMP2 z
#define BVH_WIDE_NODE_HI_Y_0_COMP3 w
#define BVH_WIDE_NODE_HI_Y_4_QUAD 9
#define BVH_WIDE_NODE_HI_Y_4_COMP x
#define BVH_WIDE_NODE_HI_Y_4_COMP1 y
#define BVH_WIDE_NODE_HI_Y_4_COMP2 z
#define BVH_WIDE_NODE_HI_Y_4_COMP3 w
#define BVH_WIDE_NODE_HI_Z_0_QUAD 10
#define BVH_WIDE_NODE_HI_Z_0_COMP x
#define BVH_WIDE_NODE_HI_Z_0_COMP1 y
#define BVH_WIDE_NODE_HI_Z_0_COMP2 z
#define BVH_WIDE_NODE_HI_Z_0_COMP3 w
#define BVH_WIDE_NODE_HI_Z_4_QUAD 11
#define BVH_WIDE_NODE_HI_Z_4_COMP x
#define BVH_WIDE_NODE_HI_Z_4_COMP1 y
#define BVH_WIDE_NODE_HI_Z_4_COMP2 z
#define BVH_WIDE_NODE_HI_Z_4_COMP3 w
#define BVH_WIDE_NODE_REF_0_QUAD 12
#define BVH_WIDE_NODE_REF_0_COMP x
#define BVH_WIDE_NODE_REF_0_COMP1 y
#define BVH_WIDE_NODE_REF_0_COMP2 z
#define BVH_WIDE_NODE_REF_0_COMP3 w
#define BVH_WIDE_NODE_REF_4_QUAD 13
#define BVH_WIDE_NODE_REF_4_COMP x
#define BVH_WIDE_NODE_REF_4_COMP1 y
#define BVH_WIDE_NODE_REF_4_COMP2 z
#define BVH_WIDE_NODE_REF_4_COMP3 w
#define BVH_WIDE_NODE_CNT_0_QUAD 14
#define BVH_WIDE_NODE_CNT_0_COMP x
#define BVH_WIDE_NODE_CNT_0_COMP1 y
#define BVH_WIDE_NODE_CNT_0_COMP2 z
#define BVH_WIDE_NODE_CNT_0_COMP3 w
#define BVH_WIDE_NODE_CNT_4_QUAD 15
#define BVH_WIDE_NODE_CNT_4_COMP x
#define BVH_WIDE_NODE_CNT_4_COMP1 y
#define BVH_WIDE_NODE_CNT_4_COMP2 z
#define BVH_WIDE_NODE_CNT_4_COMP3 w

/* a BVH leaf slot's primitive in leaf order: triangle v0, e1 = v1-v0, e2 = v2-v0; sphere (e1, pad1) = centre, radius */
typedef struct {
    float v0[3];
    uint prim;
    float e1[3];
    float pad1;
    float e2[3];
    float pad2;
} leaf_prim;
#define LEAF_PRIM_QUADS 3u
/* Every lane's record `index` of a float4 table into rec4v q0 .. q2 (render/lane_io.cl's gather_rec4). */
#define LEAF_PRIM_GATHER(q, table, index) rec4v q##0 = gather_rec4((table), (index) * 3u + 0u), q##1 = gather_rec4((table), (index) * 3u + 1u), q##2 = gather_rec4((table), (index) * 3u + 2u)
#define LEAF_PRIM_V0_QUAD 0
#define LEAF_PRIM_V0_COMP x
#define LEAF_PRIM_V0_COMP1 y
#define LEAF_PRIM_V0_COMP2 z
#define LEAF_PRIM_PRIM_QUAD 0
#define LEAF_PRIM_PRIM_COMP w
#define LEAF_PRIM_E1_QUAD 1
#define LEAF_PRIM_E1_COMP x
#define LEAF_PRIM_E1_COMP1 y
#define LEAF_PRIM_E1_COMP2 z
#define LEAF_PRIM_PAD1_QUAD 1
#define LEAF_PRIM_PAD1_COMP w
#define LEAF_PRIM_E2_QUAD 2
#define LEAF_PRIM_E2_COMP x
#define LEAF_PRIM_E2_COMP1 y
#define LEAF_PRIM_E2_COMP2 z
#define LEAF_PRIM_PAD2_QUAD 2
#define LEAF_PRIM_PAD2_COMP w

/* scalar parameters of render_blocks (kernels/render/integrator.cl) */
typedef struct {
    ulong first_block;
    ulong seed;
    uint nblocks;
    uint spp_per_block;
    uint spp_limit;
    uint width;
    uint height;
    uint tile_pixels;
    uint ntiles;
    int max_depth;
    uint rr_depth;
    uint ntris;
    uint nspheres;
    uint nlights;
    uint light_top;
    float env_threshold;
    float env_pmf;
    int bdpt_only_s;
    int bdpt_only_t;
    int bdpt_unweighted;
    int bdpt_power_mis;
    int bdpt_roulette;
    float near_clip;
    float far_clip;
    int filter_kind;
    float filter_radius;
    float filter_stddev;
    float4 env_radiance;
    uint ncasters;
    float caster_share;
    float caster_reach;
    float4 casters[8];
    float4 caster_axes[8];
} render_params;

/* scalar parameters of walk_blocks (kernels/walks/walk.cl) */
typedef struct {
    ulong first_block;
    ulong walk_limit;
    ulong seed;
    uint nwork;
    uint nq;
    uint wpb;
    float survival;
    uint depth;
    uint max_len;
} walk_params;

/* the tabulated densities of a walk: grid sizes and where each table starts in the buffer */
typedef struct {
    uint nxa;
    uint nya;
    uint nb;
    uint lognb;
    uint trans_off;
    uint q_off;
    uint src_off;
} walk_table_geometry;

#endif
