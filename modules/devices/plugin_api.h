/* The device plugin interface: a device is a shared library that exports the
 * extern "C" entry points below. Plain C so that a plugin can be written in
 * any language with a C ABI; all quantities are SI (m, N, s, N/m, N s/m).
 *
 * Versioning: palpa_device_interface() returns PALPA_DEVICE_INTERFACE. The
 * host refuses a plugin whose string differs (the message names both). Bump
 * the number on every change of a struct layout or of an entry point's
 * signature or meaning.
 *
 * Threads: palpa_device_read(), palpa_device_write() and palpa_device_feed()
 * are real-time entry points: they must not allocate, lock, block, do I/O or
 * throw, because the haptic loop calls read/write on every tick. Everything
 * else is called from ordinary threads. A plugin that talks to hardware runs
 * its own I/O thread and exchanges the latest sample and force command with
 * the real-time entry points through lock-free mailboxes.
 *
 * File names: plugin `NAME` lives in libpalpa_device_NAME.so (see
 * devices/loader.h for the search path).
 */
#ifndef PALPA_DEVICES_PLUGIN_API_H
#define PALPA_DEVICES_PLUGIN_API_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The interface string of this header. */
#define PALPA_DEVICE_INTERFACE "palpa.device/2"
/* History: palpa.device/1 had no palpa_device_options(); /2 adds it (the
 * options a plugin accepts, from which the workbench builds its forms). */

/** Return codes of the entry points that return int. */
#define PALPA_DEVICE_OK 0
#define PALPA_DEVICE_FAILED (-1)
#define PALPA_DEVICE_UNSUPPORTED (-2)

/** Status bits of a sample. */
#define PALPA_STATUS_VALID 0x1u  /**< position holds a real reading */
#define PALPA_STATUS_NOT_READY 0x2u /**< homing / calibrating / connecting: forces are not applied */
#define PALPA_STATUS_STALE 0x4u  /**< the input is too old (e.g. network): the host must send zero force */
#define PALPA_STATUS_FAULT 0x8u  /**< device error or unplugged; stays set until the device is restarted */

/** What a device can do. Filled by palpa_device_spec(). */
typedef struct PalpaDeviceSpec {
  char name[64];              /**< human-readable model, NUL-terminated */
  uint32_t position_dof;      /**< degrees of freedom read: 3 (position) or 6 (position + orientation) */
  uint32_t force_dof;         /**< degrees of freedom of force output: 0 (none) or 3 */
  double workspace_min[3];    /**< m, device frame: reachable box */
  double workspace_max[3];    /**< m, device frame */
  double max_force;           /**< N: the largest force the device may be asked for (0 when force_dof is 0) */
  double max_stiffness;       /**< N/m: the largest stable rendered stiffness */
  double max_damping;         /**< N s/m: the largest stable rendered damping */
  double nominal_rate;        /**< Hz: rate at which the device produces new samples */
  uint32_t button_count;      /**< buttons reported in PalpaDeviceSample::buttons (bit i = button i) */
} PalpaDeviceSpec;

/** One reading of the device, in the device frame. */
typedef struct PalpaDeviceSample {
  uint64_t sequence;          /**< increases with every new reading (0: none yet) */
  double time;                /**< s, CLOCK_MONOTONIC when the reading was taken */
  double position[3];         /**< m, device frame */
  double orientation[4];      /**< unit quaternion w, x, y, z; (1, 0, 0, 0) when not measured */
  uint32_t buttons;           /**< bit i set = button i pressed */
  uint32_t status;            /**< PALPA_STATUS_* bits */
} PalpaDeviceSample;

/** A force command for the device, in the device frame. */
typedef struct PalpaForceCommand {
  double force[3];            /**< N, device frame; already safe (finite, clamped) */
  double time;                /**< s, CLOCK_MONOTONIC when the command was computed */
  double expires_after;       /**< s: the device must output zero force once now > time + expires_after
                                   (the watchdog against a stalled haptic loop) */
} PalpaForceCommand;

/** Types of an option (PalpaDeviceOption::type). */
#define PALPA_OPTION_DOUBLE 1 /**< a finite number within [min, max] */
#define PALPA_OPTION_INT 2    /**< an integer within [min, max] */
#define PALPA_OPTION_BOOL 3   /**< true/false (also yes/no, on/off, 1/0) */
#define PALPA_OPTION_STRING 4 /**< free text */
#define PALPA_OPTION_FILE 5   /**< a path to an existing file the user picks */
#define PALPA_OPTION_CHOICE 6 /**< one of the '|'-separated words of `choices` */

/** Flags of an option. */
#define PALPA_OPTION_REQUIRED 0x1u /**< create() fails without it */

/** One option palpa_device_create() accepts. Every string is NUL-terminated
 *  and static (valid while the library is loaded); none is NULL. */
typedef struct PalpaDeviceOption {
  const char* name;          /**< the key, e.g. "time_scale" */
  uint32_t type;             /**< PALPA_OPTION_* */
  uint32_t flags;            /**< PALPA_OPTION_REQUIRED or 0 */
  const char* unit;          /**< SI unit of a number ("m", "N", "Hz", "s"), "" when none */
  double min, max;           /**< inclusive range of DOUBLE and INT options (0, 0 otherwise) */
  const char* default_value; /**< the value used when the option is not given, written as it would be
                                  given ("1", "false", "client"); "" when there is none */
  const char* choices;       /**< CHOICE: the accepted words separated by '|' ("client|server"); "" otherwise */
  const char* help;          /**< one or two sentences for a tooltip */
} PalpaDeviceOption;

/** Opaque plugin instance. */
typedef struct PalpaDevice PalpaDevice;

/* ---- Entry points: every plugin exports all of these ------------------- */

/** Returns PALPA_DEVICE_INTERFACE of the header the plugin was built with. */
typedef const char* (*palpa_device_interface_fn)(void);

/** Creates an instance from `options` ("key=value" pairs separated by ';' or
 *  newlines; may be NULL or empty). On failure returns NULL and writes a
 *  NUL-terminated message naming the problem into error[0 .. error_size). */
typedef PalpaDevice* (*palpa_device_create_fn)(const char* options, char* error, size_t error_size);

/** The options palpa_device_create() accepts, in the order a form shows
 *  them: returns a static array and its length in *count. Callable before
 *  any instance exists (the host builds its forms from it); the ranges are
 *  the ones create() enforces. (Added in palpa.device/2.) */
typedef const PalpaDeviceOption* (*palpa_device_options_fn)(size_t* count);

/** Destroys an instance (stops it first when started). */
typedef void (*palpa_device_destroy_fn)(PalpaDevice* device);

/** Fills `spec`. Returns PALPA_DEVICE_OK. */
typedef int (*palpa_device_spec_fn)(PalpaDevice* device, PalpaDeviceSpec* spec);

/** Opens the hardware and starts the plugin's I/O. May block for a while
 *  (connection, firmware upload). On failure returns PALPA_DEVICE_FAILED and a
 *  message in error. */
typedef int (*palpa_device_start_fn)(PalpaDevice* device, char* error, size_t error_size);

/** Stops I/O and releases the hardware, commanding zero force first. */
typedef void (*palpa_device_stop_fn)(PalpaDevice* device);

/** Real-time: copies the latest sample. Returns PALPA_DEVICE_OK. */
typedef int (*palpa_device_read_fn)(PalpaDevice* device, PalpaDeviceSample* sample);

/** Real-time: replaces the force command. Returns PALPA_DEVICE_OK
 *  (PALPA_DEVICE_UNSUPPORTED for devices without force output). */
typedef int (*palpa_device_write_fn)(PalpaDevice* device, const PalpaForceCommand* command);

/** Writes a one-line human-readable state ("homing: move the grip ...",
 *  "unplugged", "running") into buf. Returns PALPA_DEVICE_OK. */
typedef int (*palpa_device_message_fn)(PalpaDevice* device, char* buf, size_t size);

/* ---- Optional entry point ---------------------------------------------- */

/** Real-time, lock-free: the host feeds the next sample itself (the
 *  workbench's virtual probe). Exported only by host-fed devices; returns
 *  PALPA_DEVICE_OK. */
typedef int (*palpa_device_feed_fn)(PalpaDevice* device, const PalpaDeviceSample* sample);

#ifdef __cplusplus
}
#endif

#endif /* PALPA_DEVICES_PLUGIN_API_H */
