/* material.cl — a scene's materials as the BSDF kernels see them.
 *
 * Materials come from CompiledScene.materials, one material_record each
 * (layouts.cl, from mcocl/layouts.py): kind (a MaterialKind code, MAT_<NAME>,
 * one per BSDF registered in mcocl/bsdf_registry.py), rgb, alpha, int_ior,
 * ext_ior, flags.  Every BSDF's kernel file (render/bsdf_<name>.cl) reads its
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
    floatv alpha; /* GGX roughness */
    floatv eta;   /* int_ior / ext_ior */
    intv flags;   /* MAT_FLAG_* bits (render/bsdf.cl): twosided */
} material_v;

/* The material record `index` of every lane (MATERIAL_RECORD_QUADS float4 per material). */
MC_INLINE material_v material_load(global const float4 *mats, uintv index) {
    MATERIAL_RECORD_GATHER(q, mats, index);
    material_v m;
    m.kind = to_intv(REC_FIELD(q, MATERIAL_RECORD_KIND));
    m.color = REC_VEC3(q, MATERIAL_RECORD_RGB);
    m.alpha = REC_FIELD(q, MATERIAL_RECORD_ALPHA);
    m.eta = REC_FIELD(q, MATERIAL_RECORD_INT_IOR) / REC_FIELD(q, MATERIAL_RECORD_EXT_IOR);
    m.flags = to_intv(REC_FIELD(q, MATERIAL_RECORD_FLAGS));
    return m;
}

#endif
