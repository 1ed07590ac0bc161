"""Protocol facts shared by the host clients, the twin's virtual boards and the firmware.

The bottom layer: the code table (``codes``, read from ``protocol_codes.def``, which both
firmwares include), the sensor's frame format (``frames``), the MLX90393's datasheet tables
(``mlx90393``) and the sensor board's settings (``sensor_config``). No I/O, no pyserial.
"""
