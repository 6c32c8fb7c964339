/* encal test stub: the frame transform type sensor.h names in a prototype. */
#ifndef ENCAL_STUB_XFS_H
#define ENCAL_STUB_XFS_H
typedef struct FrameTransform { float offset; float multiplier; } FrameTransform;
#endif
