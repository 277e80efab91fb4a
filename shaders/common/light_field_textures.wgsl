// The light field's textures, in its group (common/light_field.wgsl; src/lightfield/textures.rs
// builds them): per face (diffuse texture, emission texture, coverage texture, cutoff bits) and
// the textures (common/textures.wgsl samples them). Included by the stages that read the
// converged light field per pixel (render.wgsl, probes.wgsl), after common/light_field.wgsl.
// Apart from it because specular transport reads the same names from its scene group
// (common/surface_textures.wgsl): in its light field group they would count twice against the
// device's storage buffers per stage.
@group(LIGHT_FIELD_GROUP) @binding(15) var<storage, read> face_textures: array<vec4<u32>>;
@group(LIGHT_FIELD_GROUP) @binding(16) var<storage, read> texture_info: array<vec4<u32>>;
@group(LIGHT_FIELD_GROUP) @binding(17) var<storage, read> texture_texels: array<vec4<f32>>;
