/* embree_mask_shim: an LD_PRELOAD library that gives every ray Open3D traces a full Embree
 * ray mask, so that Debian's python3-open3d 0.16.1 finds hits at all.
 *
 * Why: Debian builds Embree with ray masks enabled (EMBREE_RAY_MASK=ON), and a ray then only
 * sees geometry whose mask shares a bit with the ray's. Open3D 0.16.1 leaves RTCRay::mask at 0,
 * so every ray misses. `nm -D --undefined-only libOpen3D.so.0.16.1` shows that its
 * RaycastingScene traces through exactly two calls, rtcIntersect1M and rtcOccluded1M; this
 * library defines both, sets mask = 0xFFFFFFFF on each of the M rays (laid out byteStride bytes
 * apart), and forwards to the real Embree function found with dlsym(RTLD_NEXT).
 *
 * Usage: LD_PRELOAD=/path/to/libembree_mask_shim.so python3 bench/peers/open3d_peer.py ...
 * It changes nothing else: ray origin, direction, range, and the hit Embree returns are as
 * Open3D set and reads them. The cost is one store per ray. */

#define _GNU_SOURCE
#include <dlfcn.h>
#include <embree3/rtcore.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void (*Intersect1M)(RTCScene, struct RTCIntersectContext*, struct RTCRayHit*, unsigned,
                            size_t);
typedef void (*Occluded1M)(RTCScene, struct RTCIntersectContext*, struct RTCRay*, unsigned, size_t);

static Intersect1M real_intersect1m;
static Occluded1M real_occluded1m;

/* The next definition of `name` after this library; ISO C cannot cast a data pointer to a
 * function pointer, so the bytes are copied (the POSIX-sanctioned route). A missing symbol
 * means the shim is loaded into a process without Embree, where it can do nothing useful. */
static void resolve(const char* name, void* fn, size_t size) {
    void* sym = dlsym(RTLD_NEXT, name);
    if (!sym) {
        fprintf(stderr, "embree_mask_shim: %s not found: %s\n", name, dlerror());
        abort();
    }
    memcpy(fn, &sym, size);
}

/* Resolved on the first call rather than in a constructor, so that nothing depends on the order
 * in which the loader runs constructors; Open3D traces from several threads, hence pthread_once.
 * The shim is linked against libembree3 so that the preload brings Embree into the global scope,
 * where RTLD_NEXT looks (Python itself loads Open3D and its Embree with RTLD_LOCAL). */
static pthread_once_t resolved = PTHREAD_ONCE_INIT;

static void resolve_all(void) {
    resolve("rtcIntersect1M", &real_intersect1m, sizeof real_intersect1m);
    resolve("rtcOccluded1M", &real_occluded1m, sizeof real_occluded1m);
}

void rtcIntersect1M(RTCScene scene, struct RTCIntersectContext* context, struct RTCRayHit* rayhit,
                    unsigned int M, size_t byteStride) {
    for (unsigned int i = 0; i < M; ++i) {
        struct RTCRayHit* r = (struct RTCRayHit*)((char*)rayhit + i * byteStride);
        r->ray.mask = 0xFFFFFFFFu;
    }
    pthread_once(&resolved, resolve_all);
    real_intersect1m(scene, context, rayhit, M, byteStride);
}

void rtcOccluded1M(RTCScene scene, struct RTCIntersectContext* context, struct RTCRay* ray,
                   unsigned int M, size_t byteStride) {
    for (unsigned int i = 0; i < M; ++i) {
        struct RTCRay* r = (struct RTCRay*)((char*)ray + i * byteStride);
        r->mask = 0xFFFFFFFFu;
    }
    pthread_once(&resolved, resolve_all);
    real_occluded1m(scene, context, ray, M, byteStride);
}
