import { useCallback, useEffect, useRef } from 'react';
import { Icon } from '@/components/ui/Icon';
import { useSettingsStore } from '@/stores/settingsStore';
import { useToastStore } from '@/stores/toastStore';
import { sendAudio } from '../api/audio';
import { silence } from '../speech';
import { useRecorder } from '../useRecorder';

function isTyping(target: EventTarget | null): boolean {
  if (!(target instanceof HTMLElement)) return false;
  return target.isContentEditable || ['INPUT', 'TEXTAREA', 'SELECT'].includes(target.tagName);
}

/** Hold the button (or Space outside text fields) to talk; releases send the recording. */
export function PushToTalk() {
  const config = useSettingsStore((s) => s.config);
  const button = useRef<HTMLButtonElement>(null);
  const onRecording = useCallback(async (blob: Blob) => {
    await sendAudio(blob);
  }, []);
  const onError = useCallback((message: string) => useToastStore.getState().push('error', message), []);
  const { state, level, start, stop } = useRecorder(onRecording, onError);
  const available = config?.speech_input ?? false;
  const reason = config ? (config.speech_input_reason ?? '') : 'Connecting to the robot…';

  const begin = useCallback(() => {
    silence(); // barge-in: the robot stops talking while you speak
    void start();
  }, [start]);

  useEffect(() => {
    if (!available) return;
    const spaceOk = (e: KeyboardEvent) =>
      e.code === 'Space' && !isTyping(e.target) && (e.target === document.body || e.target === button.current);
    const down = (e: KeyboardEvent) => {
      if (!spaceOk(e)) return;
      e.preventDefault();
      if (!e.repeat) begin();
    };
    const up = (e: KeyboardEvent) => {
      if (!spaceOk(e)) return;
      e.preventDefault();
      stop();
    };
    window.addEventListener('keydown', down);
    window.addEventListener('keyup', up);
    return () => {
      window.removeEventListener('keydown', down);
      window.removeEventListener('keyup', up);
    };
  }, [available, begin, stop]);

  const recording = state === 'recording';
  return (
    <div className="flex items-center gap-1.5">
      <button
        ref={button}
        type="button"
        aria-label="Hold to talk"
        aria-pressed={recording}
        aria-description={available ? undefined : reason}
        disabled={!available || state === 'sending'}
        title={available ? 'Hold (or hold Space) and speak' : reason}
        onPointerDown={(e) => {
          e.preventDefault();
          // Capture: the release counts wherever the pointer is (the label changes size).
          e.currentTarget.setPointerCapture?.(e.pointerId);
          begin();
        }}
        onPointerUp={stop}
        onPointerCancel={stop}
        className={`inline-flex min-w-28 items-center justify-center gap-1.5 rounded-full border px-3 py-2 text-sm font-medium focus-visible:outline-2 focus-visible:outline-accent
          disabled:cursor-not-allowed disabled:opacity-50 ${
            recording ? 'border-status-failed bg-status-failed text-danger-fg' : 'border-line bg-raised text-fg'
          }`}
      >
        <Icon name="mic" />
        {recording ? 'Listening…' : state === 'sending' ? 'Sending…' : 'Talk'}
      </button>
      {recording && (
        <meter aria-label="Microphone level" min={0} max={1} value={level} className="w-12" />
      )}
      {!available && config && (
        <span className="hidden text-xs text-muted sm:inline" title={reason}>
          voice off
        </span>
      )}
    </div>
  );
}
