/* material.cl — a scene's materials as the BSDF kernels see them.
 *
 * Materials come from CompiledScene.materials, one material_record each
 * (layouts.cl, from mcocl/layouts.py): kind (a MaterialKind code, MAT_<NAME>,
 * one per BSDF registered in mcocl/bsdf_registry.py), rgb, alpha, int_ior,
 * ext_ior, flags, and the extended alpha_second, eta_rgb, k_rgb, table, transmittance_rgb.  Every
 * BSDF kernel file (render/bsdf_<name>.cl) reads its parameters from a material_v; the dispatcher render/bsdf.cl is generated.
 */
#ifndef MCOCL_MATERIAL_CL
#define MCOCL_MATERIAL_CL

#include "layouts.cl"
#include "render/vec3.cl"
#include "sampling/gather.cl"
#include "render/lane_io.cl"

typedef struct {
    intv kind;
    vec3v color;  /* albedo (diffuse), specular reflectance (conductors, dielectrics) */
    vec3v transmit; /* a dielectric's specular transmittance: color unless MAT_FLAG_TRANSMITTANCE */
    floatv alpha; /* roughness (along the first tangent when anisotropic) */
    floatv eta;   /* int_ior / ext_ior */
    intv flags;   /* MAT_FLAG_* bits (render/bsdf.cl): twosided, beckmann, anisotropic, complex_ior, tabulated */
    /* Where the record is, for the extended fields: the BSDFs read them (material_alpha_second,
     * material_conductor_ior, material_table) only for lanes whose flags ask for them, so
     * that other materials carry and load nothing more. */
    global const float4 *mats;
    uintv index;
} material_v;

/* The material record `index` of every lane (MATERIAL_RECORD_QUADS float4 per material):
 * its first two float4; the extended two are read on demand (below). */
MC_INLINE material_v material_load(global const float4 *mats, uintv index) {
    rec4v q0 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 0u);
    rec4v q1 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 1u);
    material_v m;
    m.kind = to_intv(REC_FIELD(q, MATERIAL_RECORD_KIND));
    m.color = REC_VEC3(q, MATERIAL_RECORD_RGB);
    m.alpha = REC_FIELD(q, MATERIAL_RECORD_ALPHA);
    m.eta = REC_FIELD(q, MATERIAL_RECORD_INT_IOR) / REC_FIELD(q, MATERIAL_RECORD_EXT_IOR);
    m.flags = to_intv(REC_FIELD(q, MATERIAL_RECORD_FLAGS));
    m.mats = mats;
    m.index = index;
    /* the record's last quad only where a dielectric's two tints differ (mcocl/bsdf_registry.py,
     * transmittance_flag): other materials load nothing more */
    m.transmit = m.color;
    intv split = (m.flags & MAT_FLAG_TRANSMITTANCE) != 0;
    if (lane_any(split)) {
        rec4v q4 = gather_rec4(mats, index * MATERIAL_RECORD_QUADS + 4u);
        m.transmit = v3_select(m.transmit, REC_VEC3(q, MATERIAL_RECORD_TRANSMITTANCE_RGB), split);
    }
    return m;
}

/* The roughness along the second tangent (MAT_FLAG_ANISOTROPIC). */
MC_INLINE floatv material_alpha_second(const material_v *m) {
    rec4v q2 = gather_rec4(m->mats, m->index * MATERIAL_RECORD_QUADS + 2u);
    return REC_FIELD(q, MATERIAL_RECORD_ALPHA_SECOND);
}

/* A conductor's complex index of refraction eta + i k (MAT_FLAG_COMPLEX_IOR). */
MC_INLINE void material_conductor_ior(const material_v *m, vec3v *eta, vec3v *k) {
    rec4v q2 = gather_rec4(m->mats, m->index * MATERIAL_RECORD_QUADS + 2u);
    rec4v q3 = gather_rec4(m->mats, m->index * MATERIAL_RECORD_QUADS + 3u);
    *eta = REC_VEC3(q, MATERIAL_RECORD_ETA_RGB);
    *k = REC_VEC3(q, MATERIAL_RECORD_K_RGB);
}

/* The first float of the material's table in the materials table (MAT_FLAG_TABULATED). */
MC_INLINE floatv material_table(const material_v *m) {
    rec4v q3 = gather_rec4(m->mats, m->index * MATERIAL_RECORD_QUADS + 3u);
    return REC_FIELD(q, MATERIAL_RECORD_TABLE);
}

#endif
