/* encal test harness (written for encal): runs Tinymovr's own sensor_get_angle_rectified (sensor.h) on
 * every requested raw angle, with a table copied element by element into SensorConfig.rec_table. */
#include <string.h>
#include <src/sensor/sensor.h>

static int32_t current_angle;

static int32_t raw_angle(const Sensor *s)
{
    (void)s;
    return current_angle;
}

int encal_rectified(const int32_t *table, int bits, const int32_t *angles, int count, int32_t *out)
{
    Sensor s;
    memset(&s, 0, sizeof s);
    for (int i = 0; i < ECN_SIZE; i++)
        s.config.rec_table[i] = table[i];
    s.config.rec_calibrated = true;
    s.get_raw_angle_func = raw_angle;
    s.bits = (uint8_t)bits;
    s.ticks = 1u << bits;
    for (int i = 0; i < count; i++)
    {
        current_angle = angles[i];
        out[i] = sensor_get_angle_rectified(&s);
    }
    return (int)sizeof(s.config.rec_table[0]);
}
