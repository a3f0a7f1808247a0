import { useCallback, useEffect, useRef, useState } from 'react';

export type RecorderState = 'idle' | 'starting' | 'recording' | 'sending';

/** MediaRecorder + a level meter (0..1) from an AnalyserNode. */
export function useRecorder(onRecording: (blob: Blob) => Promise<void>, onError: (message: string) => void) {
  const [state, setState] = useState<RecorderState>('idle');
  const [level, setLevel] = useState(0);
  const recorder = useRef<MediaRecorder | null>(null);
  const cleanup = useRef<(() => void) | null>(null);
  const wanted = useRef(false);

  const release = () => {
    cleanup.current?.();
    cleanup.current = null;
    setLevel(0);
  };

  const start = useCallback(async () => {
    if (recorder.current || wanted.current) return;
    wanted.current = true;
    setState('starting');
    let stream: MediaStream;
    try {
      // The recognizer wants the voice as the microphone hears it: the browser's noise
      // suppression and gain control reshape it (the on-board recognizer then scored the
      // right sentence too low to act on). Echo cancellation stays: the robot may be talking.
      stream = await navigator.mediaDevices.getUserMedia({
        audio: { echoCancellation: true, noiseSuppression: false, autoGainControl: false },
      });
    } catch (err) {
      wanted.current = false;
      setState('idle');
      onError(`Microphone unavailable: ${err instanceof Error ? err.message : String(err)}`);
      return;
    }
    const context = new AudioContext();
    const analyser = context.createAnalyser();
    analyser.fftSize = 512;
    context.createMediaStreamSource(stream).connect(analyser);
    const samples = new Uint8Array(analyser.fftSize);
    let frame = 0;
    const meter = () => {
      analyser.getByteTimeDomainData(samples);
      let peak = 0;
      for (const v of samples) peak = Math.max(peak, Math.abs(v - 128) / 128);
      setLevel(peak);
      frame = requestAnimationFrame(meter);
    };
    frame = requestAnimationFrame(meter);
    const chunks: Blob[] = [];
    const rec = new MediaRecorder(stream);
    rec.ondataavailable = (e) => e.data.size > 0 && chunks.push(e.data);
    rec.onstop = () => {
      const blob = new Blob(chunks, { type: rec.mimeType || 'audio/webm' });
      recorder.current = null;
      release();
      if (blob.size === 0) {
        setState('idle');
        onError('Nothing was recorded: hold the button (or Space) while you speak.');
        return;
      }
      setState('sending');
      onRecording(blob)
        .catch((err: unknown) => onError(`Voice turn failed: ${err instanceof Error ? err.message : String(err)}`))
        .finally(() => setState('idle'));
    };
    cleanup.current = () => {
      cancelAnimationFrame(frame);
      stream.getTracks().forEach((t) => t.stop());
      void context.close();
    };
    recorder.current = rec;
    rec.start(250); // timeslices: Chromium delivers only a header when stopped without them
    setState('recording');
    if (!wanted.current) rec.stop(); // released before the microphone opened
  }, [onRecording, onError]);

  const stop = useCallback(() => {
    wanted.current = false;
    if (recorder.current?.state === 'recording') recorder.current.stop();
  }, []);

  useEffect(() => () => release(), []);
  return { state, level, start, stop };
}
