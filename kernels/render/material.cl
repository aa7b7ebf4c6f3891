/* material.cl — a scene's materials as the BSDF kernels see them.
 *
 * Materials come from CompiledScene.materials, one material_record each
 * (layouts.cl, from mcocl/layouts.py): kind (a MaterialKind code, MAT_<NAME>,
 * one per BSDF registered in mcocl/bsdf_registry.py), rgb, alpha, int_ior,
 * ext_ior, flags, and the extended alpha_second, eta_rgb, k_rgb.  Every BSDF kernel file (render/bsdf_<name>.cl) reads its
 * parameters from a material_v; the dispatcher render/bsdf.cl is generated.
 */
#ifndef MCOCL_MATERIAL_CL
#define MCOCL_MATERIAL_CL

#include "layouts.cl"
#include "render/vec3.cl"
#include "sampling/gather.cl"
#include "render/lane_io.cl"

typedef struct {
    intv kind;
    vec3v color;  /* albedo (diffuse), specular reflectance (conductors), tint (dielectric) */
    floatv alpha; /* roughness (along the first tangent when anisotropic) */
    floatv eta;   /* int_ior / ext_ior */
    intv flags;   /* MAT_FLAG_* bits (render/bsdf.cl): twosided, beckmann, anisotropic, complex_ior */
    /* The extended fields: read from the record only where a lane's flags ask for them
     * (MAT_FLAGS_EXTENDED), so that materials without them pay one test. */
    floatv alpha_v;   /* roughness along the second tangent; alpha where not anisotropic */
    vec3v cond_eta;   /* a conductor's complex index of refraction (MAT_FLAG_COMPLEX_IOR) */
    vec3v cond_k;
    floatv table;     /* the first float of the material's table in `base` (MAT_FLAG_TABULATED) */
    global const float *base;  /* the materials table, for the tables after its records */
} material_v;

/* Bits of material_record.flags that make material_load read the record's extended
 * fields (mcocl/bsdf_registry.py FLAG_BITS: anisotropic 4, complex_ior 8, tabulated 16). */
#define MAT_FLAGS_EXTENDED 28

/* The material record `index` of every lane (MATERIAL_RECORD_QUADS float4 per material):
 * its first two float4 always, the extended two only when some lane's flags ask for them. */
MC_INLINE material_v material_load(global const float4 *mats, uintv index) {
    rec4v q0 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 0u);
    rec4v q1 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 1u);
    material_v m;
    m.kind = to_intv(REC_FIELD(q, MATERIAL_RECORD_KIND));
    m.color = REC_VEC3(q, MATERIAL_RECORD_RGB);
    m.alpha = REC_FIELD(q, MATERIAL_RECORD_ALPHA);
    m.eta = REC_FIELD(q, MATERIAL_RECORD_INT_IOR) / REC_FIELD(q, MATERIAL_RECORD_EXT_IOR);
    m.flags = to_intv(REC_FIELD(q, MATERIAL_RECORD_FLAGS));
    m.alpha_v = m.alpha;
    m.cond_eta = v3s(0.0f);
    m.cond_k = v3s(0.0f);
    m.table = (floatv)(0.0f);
    m.base = (global const float *)mats;
    intv ext = (m.flags & MAT_FLAGS_EXTENDED) != 0;
    if (lane_any(ext)) {
        rec4v q2 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 2u);
        rec4v q3 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 3u);
        m.alpha_v = lane_select(m.alpha_v, REC_FIELD(q, MATERIAL_RECORD_ALPHA_SECOND), ext);
        m.cond_eta = v3_select(m.cond_eta, REC_VEC3(q, MATERIAL_RECORD_ETA_RGB), ext);
        m.cond_k = v3_select(m.cond_k, REC_VEC3(q, MATERIAL_RECORD_K_RGB), ext);
        m.table = lane_select(m.table, REC_FIELD(q, MATERIAL_RECORD_TABLE), ext);
    }
    return m;
}

#endif
